"""Where an image's indirect error sits: at geometric edges or inside surfaces.

    benches/peers/error_split.sh REFERENCE.exr IMAGE [IMAGE ...] [--minus AB0.hdr] [--downsample 4]

Each IMAGE is a radsplat EXR (its `indirect` layer) or, with --minus, an rpict picture whose
indirect light is IMAGE minus the `-ab 0` picture (as fronts.py measures it). After an N x N
box filter, a block is an *edge* block when the reference's normals in it differ by more than
0.05 or its depths by more than 2 % of their mean (silhouettes, creases, corners). The indirect
relative RMSE is then split in quadrature into its edge and interior parts:
total^2 = edge^2 + interior^2, each the block errors' sum over its blocks divided by all blocks.

rpict pictures are decoded by Radiance's own `pvalue`, which takes each RGBE mantissa at the
middle of its step (m + 0.5); `radsplat compare` truncates (m), so an rpict total here can
differ from fronts.py's by a few hundredths of a point (Sponza defaults: 20.04 against 19.98 %).
"""

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from compare_peers import radiance_dirs


def read_exr(path, layer):
    import OpenEXR
    with OpenEXR.File(str(path)) as f:
        p = np.asarray(f.channels()[layer].pixels, dtype=np.float64)
    return p[..., :3] if p.ndim == 3 else p


def read_hdr(path, bindir, env):
    raw = subprocess.run([str(bindir / "pvalue"), "-h", "-H", "-df", str(path)],
                         capture_output=True, env=env, check=True).stdout
    dims = subprocess.run([str(bindir / "getinfo"), "-d", str(path)], capture_output=True,
                          env=env, check=True).stdout.decode().split(":")[-1].split()
    h, w = int(dims[1]), int(dims[3])  # "-Y h +X w"
    return np.frombuffer(raw, dtype=np.float32).reshape(h, w, 3).astype(np.float64)


def blocks(a, n):
    h, w = a.shape[:2]
    h, w = h - h % n, w - w % n
    return a[:h, :w].reshape(h // n, n, w // n, n, *a.shape[2:])


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("reference", type=Path)
    ap.add_argument("images", type=Path, nargs="+")
    ap.add_argument("--minus", type=Path, default=None,
                    help="rpict -ab 0 picture subtracted from every .hdr image")
    ap.add_argument("--downsample", type=int, default=4)
    args = ap.parse_args()
    bindir, libdir = radiance_dirs()
    env = dict(os.environ, RAYPATH=f".:{libdir}")
    n = args.downsample
    ref = read_exr(args.reference, "indirect")
    normal = np.stack([read_exr(args.reference, f"normal.{c}") for c in "XYZ"], -1)
    depth = read_exr(args.reference, "depth.Z")
    nb = blocks(normal, n)
    spread = np.linalg.norm(nb - nb.mean((1, 3), keepdims=True), axis=-1).max((1, 3))
    db = blocks(depth, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        drel = (db.max((1, 3)) - db.min((1, 3))) / np.abs(db.mean((1, 3)))
    edge = (spread > 0.05) | ~(drel <= 0.02)
    b = blocks(ref, n).mean((1, 3))
    norm = (b ** 2).mean()
    ab0 = read_hdr(args.minus, bindir, env) if args.minus else None
    print(f"edge blocks: {100 * edge.mean():.1f} % of {edge.size} ({n}x{n})")
    print(f"{'image':48s} {'total %':>8s} {'edge %':>8s} {'interior %':>10s}")
    for img in args.images:
        if img.suffix == ".hdr":
            if ab0 is None:
                sys.exit(f"{img}: an rpict picture needs --minus (its -ab 0 picture)")
            a = read_hdr(img, bindir, env) - ab0
        else:
            a = read_exr(img, "indirect")
        e = ((blocks(a, n).mean((1, 3)) - b) ** 2).sum(-1) / 3.0
        part = lambda m: 100 * np.sqrt(e[m].sum() / e.size / norm)
        print(f"{img.name:48s} {part(np.ones_like(edge)):8.2f} {part(edge):8.2f} "
              f"{part(~edge):10.2f}")


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    main()
