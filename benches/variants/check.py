#!/usr/bin/env python3
"""Renders every still variant in this folder and compares it with its reference.

For each variant: the indirect light's relative RMSE after a 4x4 box filter, the share of
the reference's lit 4x4 blocks where the render's indirect light is exactly zero (issue 17
asks for none), the ratio of the render's mean indirect light to the reference's (a bias),
the share of the squared error in the worst 1 % of blocks (near 1 %: noise everywhere; far
above: a few blocks hold it, and record placement decides the error), and the render's
wall time. References are rendered once per variant,
spp and seed, and kept in the output folder; the renders are redone on every run.

    benches/variants/check.py [--bin target/release/radsplat] [--spp 1024] [--out DIR]
        [--only nave-west,nave-bare] [-- extra render flags]

Variants that need a model outside the repo (Sponza, the conference room) are skipped,
with a line saying so, when RADSPLAT_ASSET_PATH does not find it. Standard library only.
"""

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

# The still variants, in the order of README.md; nave-walk.toml is an animation.
VARIANTS = [
    "nave-west",
    "nave-bare",
    "nave-sun-34",
    "nave-sun-17",
    "sponza-east",
    "sponza-sun-west",
    "conference-west",
]
# The model each variant needs from RADSPLAT_ASSET_PATH (None: in the repo).
ASSETS = {
    "sponza-east": "dabrovic-sponza/sponza.obj",
    "sponza-sun-west": "dabrovic-sponza/sponza.obj",
    "conference-west": "conference/conference_geometry_only.obj",
}


def found(asset):
    if asset is None:
        return True
    paths = os.environ.get("RADSPLAT_ASSET_PATH", "").split(":")
    return any(p and os.path.exists(os.path.join(p, asset)) for p in paths)


def sha256_prefix(path):
    """The first 12 hex digits of the file's SHA-256 (which build ran)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()[:12]


def run(cmd):
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"failed ({result.returncode}): {' '.join(cmd)}\n{result.stderr}")
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "radsplat"))
    ap.add_argument("--spp", type=int, default=1024, help="reference bounce samples per pixel")
    ap.add_argument("--seed", type=int, default=1, help="reference seed")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "variants"))
    ap.add_argument("--only", default=None, help="comma-separated variant names")
    ap.add_argument("flags", nargs="*", help="extra `radsplat render` flags (after --)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    names = args.only.split(",") if args.only else VARIANTS
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        sys.exit(f"unknown variants: {', '.join(unknown)} (known: {', '.join(VARIANTS)})")
    # Which build made these numbers: a rebuilt target/release is easy to mistake for
    # another (stop 66 measured an experiment's build for a while as the default one).
    print(f"# {args.bin} (sha256 {sha256_prefix(args.bin)}), flags: {' '.join(args.flags) or 'none'}")
    print(f"{'variant':18s} {'error %':>8s} {'zero blocks %':>14s} {'mean ratio':>10s} "
          f"{'worst 1 %':>9s} {'wall s':>7s}")
    for name in names:
        if not found(ASSETS.get(name)):
            print(f"{name:18s} skipped: {ASSETS[name]} not along RADSPLAT_ASSET_PATH")
            continue
        scene = os.path.join(HERE, f"{name}.toml")
        ref = os.path.join(args.out, f"{name}-ref-{args.spp}spp-seed{args.seed}.exr")
        if not os.path.exists(ref):
            run([args.bin, "reference", scene, "--spp", str(args.spp), "--seed",
                 str(args.seed), "-o", ref, "--quiet"])
        img = os.path.join(args.out, f"{name}.exr")
        t0 = time.monotonic()
        run([args.bin, "render", scene, "-o", img, "--quiet"] + args.flags)
        wall = time.monotonic() - t0
        cmp_json = os.path.join(args.out, f"{name}-compare.json")
        run([args.bin, "compare", img, ref, "--downsample", "4", "--json", cmp_json])
        with open(cmp_json) as f:
            c = json.load(f)
        error = 100 * c["indirect"]["relative_rmse"]
        zero = 100 * c["indirect_unlit"]
        ratio = c["indirect"]["mean_ratio"]
        worst = 100 * c["indirect"]["worst_share"]
        print(f"{name:18s} {error:8.2f} {zero:14.3f} {ratio:10.3f} {worst:8.1f}% {wall:7.2f}",
              flush=True)


if __name__ == "__main__":
    main()
