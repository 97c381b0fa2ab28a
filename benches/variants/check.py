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


def select_variants(only):
    """The variants `--only` names (comma-separated; None: all), in VARIANTS's order of
    mention; exits naming any unknown one."""
    names = only.split(",") if only else VARIANTS
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        sys.exit(f"unknown variants: {', '.join(unknown)} (known: {', '.join(VARIANTS)})")
    return names


def reference(binary, scene, path, spp, seed, size=None):
    """Renders `scene`'s reference to `path` once (kept: later calls find it)."""
    if os.path.exists(path):
        return
    size_flags = ["--size", size] if size else []
    run([binary, "reference", scene, *size_flags, "--spp", str(spp), "--seed", str(seed),
         "-o", path, "--quiet"])


def render(binary, scene, path, flags, size=None):
    """Renders `scene` to `path`; returns the wall time in seconds."""
    size_flags = ["--size", size] if size else []
    t0 = time.monotonic()
    run([binary, "render", scene, *size_flags, "-o", path, "--quiet"] + flags)
    return time.monotonic() - t0


def compare(binary, img, ref, json_path):
    """`radsplat compare` of `img` against `ref` after a 4x4 box filter: its JSON."""
    run([binary, "compare", img, ref, "--downsample", "4", "--json", json_path])
    with open(json_path) as f:
        return json.load(f)


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
    names = select_variants(args.only)
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
        reference(args.bin, scene, ref, args.spp, args.seed)
        img = os.path.join(args.out, f"{name}.exr")
        wall = render(args.bin, scene, img, args.flags)
        c = compare(args.bin, img, ref, os.path.join(args.out, f"{name}-compare.json"))
        error = 100 * c["indirect"]["relative_rmse"]
        zero = 100 * c["indirect_unlit"]
        ratio = c["indirect"]["mean_ratio"]
        worst = 100 * c["indirect"]["worst_share"]
        print(f"{name:18s} {error:8.2f} {zero:14.3f} {ratio:10.3f} {worst:8.1f}% {wall:7.2f}",
              flush=True)


if __name__ == "__main__":
    main()
