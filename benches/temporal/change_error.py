#!/usr/bin/env python3
"""How wrong a sequence's frame-to-frame changes are, with the reference's own noise taken
out, and where (docs/results.md, "Glossy Spheres' flicker against 1,024-spp references").

For frames f-1, f of a sequence A and a reference R, the change error is
`(A(f) - A(f-1)) - (R(f) - R(f-1))` per pixel (luminance). Its mean square holds twice the
reference's noise variance; given a second, noisier reference R2 of the same frames with
`ratio` times fewer samples per pixel, `var(R2 - R) = (ratio + 1) var(R)`, which this
subtracts. Pixels are split by what their depth did between the two frames: `static`
(unchanged), `moving` (changed by under --jump metres: on a moving object) and `jump` (an
object's silhouette passed). Relative to the reference's mean luminance. Needs numpy and
OpenEXR (benches/peers/.venv).

    python3 benches/temporal/change_error.py --frames 0..5 \\
        --reference 'r1024/ref-####.exr' --noisy-reference 'r256/ref-####.exr' --ratio 4 \\
        'auto/frame_####.exr' 'perframe/frame_####.exr' [--downsample 1 2 4]
"""
import argparse

import numpy as np
import OpenEXR


def luminance(path, channel="RGBA"):
    x = np.asarray(OpenEXR.File(path).channels()[channel].pixels, dtype=np.float64)
    return 0.2126 * x[..., 0] + 0.7152 * x[..., 1] + 0.0722 * x[..., 2]


def depth(path):
    return np.asarray(OpenEXR.File(path).channels()["depth.Z"].pixels, dtype=np.float64)


def down(x, d):
    if d == 1:
        return x
    h, w = x.shape
    return x[: h // d * d, : w // d * d].reshape(h // d, d, w // d, d).mean(axis=(1, 3))


def frame_path(pattern, f):
    hashes = pattern.count("#")
    return pattern.replace("#" * hashes, str(f).zfill(hashes))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sequences", nargs="+", help="EXR patterns with #### for the frame")
    ap.add_argument("--frames", required=True, help="A..B, inclusive")
    ap.add_argument("--reference", required=True)
    ap.add_argument("--noisy-reference", required=True)
    ap.add_argument("--ratio", type=float, default=4.0, help="spp of reference / noisy one")
    ap.add_argument("--jump", type=float, default=0.05)
    ap.add_argument("--downsample", type=int, nargs="+", default=[1, 2, 4])
    args = ap.parse_args()
    a, b = (int(x) for x in args.frames.split(".."))
    frames = list(range(a, b + 1))
    ref = [luminance(frame_path(args.reference, f)) for f in frames]
    noisy = [luminance(frame_path(args.noisy_reference, f)) for f in frames]
    mean = np.mean([r.mean() for r in ref])
    pct = lambda ms: 100.0 * np.sqrt(max(ms, 0.0)) / mean
    for d in args.downsample:
        noise = np.mean([np.mean((down(n, d) - down(r, d)) ** 2) for n, r in zip(noisy, ref)])
        noise /= args.ratio + 1.0
        print(f"{d}x{d}: reference noise {pct(noise):.3f} %")
        for seq in args.sequences:
            lum = [down(luminance(frame_path(seq, f)), d) for f in frames]
            dep = [depth(frame_path(seq, f)) for f in frames]
            rd = [down(r, d) for r in ref]
            total, parts = 0.0, {"static": 0.0, "moving": 0.0, "jump": 0.0}
            pairs = len(frames) - 1
            for i in range(1, len(frames)):
                e = ((lum[i] - lum[i - 1]) - (rd[i] - rd[i - 1])) ** 2
                total += e.mean() / pairs
                if d == 1:
                    dz = np.abs(dep[i] - dep[i - 1])
                    classes = {
                        "static": dz <= 1e-4,
                        "moving": (dz > 1e-4) & (dz < args.jump),
                        "jump": dz >= args.jump,
                    }
                    for k, m in classes.items():
                        parts[k] += e[m].sum() / e.size / pairs
            line = f"  {seq}: change error {pct(total):.3f} %, noise-corrected {pct(total - 2 * noise):.3f} %"
            if d == 1:
                line += " (" + ", ".join(f"{k} {pct(v):.3f} %" for k, v in parts.items()) + ")"
            print(line)


if __name__ == "__main__":
    main()
