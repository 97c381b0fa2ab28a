#!/usr/bin/env python3
"""Every frame's error under temporal caching against per-frame computation's (issue 18's
aim on cube in a box: every frame within 1.25x; docs/results.md, "Replacements inside a
moving object").

Renders frames A..B of a scene with each variant (`radsplat animate` with the flags given;
every run timed, the runs of all variants interleaved, the median reported), compares each frame's indirect light (the EXR's `indirect.*`) with a
256-spp reference of that frame (made once with `radsplat reference`, kept in --refs) by
`radsplat compare-seq --json`, and prints per variant: median wall seconds, indirect
relative RMSE mean and max over frames, beauty RMSE and flicker, and the worst ratio of a
frame's indirect error to that frame's error under the baseline (the last variant).

    python3 benches/temporal/worst_frame.py scenes/cube-in-box-anim.toml --frames 0..23 \\
        --size 48x48 --runs 3 --refs out/cube-refs \\
        --variant 'default=--plane-resolution 16' \\
        --variant 'refined=--plane-resolution 16 --temporal-refine' \\
        --variant 'per frame=--plane-resolution 16 --temporal off'

Needs RADSPLAT_ASSET_PATH only for scenes that use shared assets. Standard library only.
"""
import argparse
import json
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def frame_range(text):
    a, _, b = text.partition("..")
    return int(a), int(b or a)


def run(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--frames", required=True, help="A..B, inclusive")
    ap.add_argument("--size", required=True, help="WxH")
    ap.add_argument("--spp", type=int, default=256, help="reference samples per pixel")
    ap.add_argument("--runs", type=int, default=3, help="timed runs per variant")
    ap.add_argument("--refs", required=True, help="folder of the references (reused)")
    ap.add_argument("--variant", action="append", required=True,
                    help="NAME=FLAGS for radsplat animate, or NAME@BINARY=FLAGS to run another "
                         "build (an earlier stop's, side by side); the last one is the baseline")
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "radsplat"))
    args = ap.parse_args()
    first, last = frame_range(args.frames)
    refs = Path(args.refs)
    refs.mkdir(parents=True, exist_ok=True)
    for f in range(first, last + 1):
        ref = refs / f"ref_{f:04d}.exr"
        if not ref.exists():
            run([args.bin, "reference", args.scene, "--frame", str(f), "--spp", str(args.spp),
                 "--size", args.size, "-o", str(ref), "--quiet"])
    variants = []
    binaries = {}
    for v in args.variant:
        name, _, flags = v.partition("=")
        name, _, binary = name.partition("@")
        binaries[name] = binary or args.bin
        variants.append((name, shlex.split(flags)))
    out = Path(tempfile.mkdtemp(prefix="radsplat-worst-frame-"))
    results = {}
    # Runs interleaved (variant by variant within each round) so that a slow spell of
    # the machine lands on every variant alike.
    times = {name: [] for name, _ in variants}
    for _ in range(args.runs):
        for name, flags in variants:
            folder = out / name.replace(" ", "_")
            folder.mkdir(exist_ok=True)
            times[name].append(run([binaries[name], "animate", args.scene, "--frames", args.frames,
                                    "--size", args.size, "-o", str(folder / "f_####.exr"),
                                    "--quiet", *flags]))
    for name, _ in variants:
        folder = out / name.replace(" ", "_")
        js = folder / "compare.json"
        subprocess.run([args.bin, "compare-seq", str(folder / "f_####.exr"),
                        str(refs / "ref_####.exr"), "--frames", args.frames, "--json", str(js)],
                       check=True, stdout=subprocess.DEVNULL)
        d = json.loads(js.read_text())
        indirect = [fr["comparison"]["indirect"]["relative_rmse"] * 100 for fr in d["frames"]]
        results[name] = {
            "wall_s": statistics.median(times[name]),
            "indirect": indirect,
            "beauty": d["summary"]["mean_relative_rmse"] * 100,
            "flicker": (d["summary"]["mean_flicker_relative"] or 0.0) * 100,
        }
    base = results[variants[-1][0]]["indirect"]
    print(f"{args.scene} frames {args.frames} at {args.size}, {args.spp}-spp references; "
          f"wall: median of {args.runs}; worst frame against '{variants[-1][0]}'")
    print(f"{'variant':<24} {'wall s':>7} {'indirect mean':>13} {'max':>6} {'beauty':>7} "
          f"{'flicker':>7} {'worst frame':>14}")
    for name, _ in variants:
        r = results[name]
        ratios = [a / b for a, b in zip(r["indirect"], base)]
        worst = max(range(len(ratios)), key=ratios.__getitem__)
        print(f"{name:<24} {r['wall_s']:7.2f} {statistics.mean(r['indirect']):12.2f}% "
              f"{max(r['indirect']):5.2f}% {r['beauty']:6.3f}% {r['flicker']:6.3f}% "
              f"{ratios[worst]:6.2f}x ({first + worst:3d})")
    print("per frame, indirect %:")
    for name, _ in variants:
        print(f"  {name:<22} " + " ".join(f"{x:.2f}" for x in results[name]["indirect"]))
    print(f"images in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
