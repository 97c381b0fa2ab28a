#!/usr/bin/env python3
"""Compares radsplat builds (or flag sets) on every still variant at several image sizes.

One size says little where a few 4x4 blocks hold most of a variant's error (`check.py`'s
"worst 1 %" column): there, which pixel lands on which record decides the error, and a
change that moves records wins or loses by chance (docs/results.md, stop 66: nave-sun-34
ranged over 6.2-13.5 % at five sizes with the same build). This renders each variant at
its own size and at sizes around it, each against a reference of that size, and prints
per variant the mean error and wall time of every build and how often each beats the
first.

    benches/variants/sizes.py [--out DIR] [--only a,b] [--spp 1024] [--steps -2,-1,1,2]
        [--step 8] LABEL=BIN[:FLAGS] LABEL=BIN[:FLAGS] ...

A build is `LABEL=BINARY`, optionally followed by `:` and render flags separated by
spaces, e.g. `base=target/release/radsplat` `rmin3=target/release/radsplat:--r-min-pixels 3`.
Sizes: the variant's own width and height plus `steps` times `step` pixels each (kept
square where the variant is, a multiple of 4 for the 4x4 box filter). References are
rendered once per variant, size, spp and seed and kept in DIR. Standard library only;
needs RADSPLAT_ASSET_PATH for the Sponza and conference variants (skipped with a line
when their model is not found).
"""

import argparse
import os
import re
import statistics
import sys

from check import (ASSETS, ROOT, compare, found, reference, render, select_variants,
                   sha256_prefix)

HERE = os.path.dirname(os.path.abspath(__file__))


def own_size(scene):
    """The `resolution = [w, h]` of the variant's [camera] section."""
    with open(scene) as f:
        m = re.search(r"^resolution\s*=\s*\[\s*(\d+)\s*,\s*(\d+)\s*\]", f.read(), re.M)
    if not m:
        sys.exit(f"{scene}: no resolution")
    return int(m.group(1)), int(m.group(2))


def parse_build(spec):
    label, sep, rest = spec.partition("=")
    if not sep or not label or not rest:
        sys.exit(f"a build is LABEL=BINARY[:FLAGS], not {spec!r}")
    binary, _, flags = rest.partition(":")
    return label, binary, flags.split()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "variant-sizes"))
    ap.add_argument("--only", default=None, help="comma-separated variant names")
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", default="-2,-1,1,2", help="size steps around the variant's own")
    ap.add_argument("--step", type=int, default=8, help="pixels per step (a multiple of 4)")
    ap.add_argument("--ref-bin", default=os.path.join(ROOT, "target", "release", "radsplat"),
                    help="the build that renders the references and compares")
    ap.add_argument("builds", nargs="+", help="LABEL=BINARY[:FLAGS]")
    args = ap.parse_args()
    if args.step % 4 != 0 or args.step <= 0:
        sys.exit("--step must be a positive multiple of 4")
    builds = [parse_build(b) for b in args.builds]
    steps = [0] + [int(s) for s in args.steps.split(",") if s.strip()]
    names = select_variants(args.only)
    os.makedirs(args.out, exist_ok=True)
    for label, binary, flags in builds:
        print(f"# {label}: {binary} (sha256 {sha256_prefix(binary)}), "
              f"flags: {' '.join(flags) or 'none'}")
    for name in names:
        if not found(ASSETS.get(name)):
            print(f"{name}: skipped, {ASSETS[name]} not along RADSPLAT_ASSET_PATH")
            continue
        scene = os.path.join(HERE, f"{name}.toml")
        w0, h0 = own_size(scene)
        errors = {label: [] for label, _, _ in builds}
        walls = {label: [] for label, _, _ in builds}
        sizes = []
        for k in steps:
            w, h = w0 + k * args.step, h0 + k * args.step * h0 // w0
            w, h = w - w % 4, h - h % 4
            if w < 16 or h < 16:
                continue
            sizes.append(f"{w}x{h}")
            ref = os.path.join(args.out, f"{name}-{w}x{h}-ref-{args.spp}spp-seed{args.seed}.exr")
            reference(args.ref_bin, scene, ref, args.spp, args.seed, f"{w}x{h}")
            line = []
            for label, binary, flags in builds:
                img = os.path.join(args.out, f"{name}-{w}x{h}-{label}.exr")
                walls[label].append(render(binary, scene, img, flags, f"{w}x{h}"))
                c = compare(args.ref_bin, img, ref,
                            os.path.join(args.out, f"{name}-{w}x{h}-{label}.json"))
                error = 100 * c["indirect"]["relative_rmse"]
                errors[label].append(error)
                line.append(f"{label} {error:6.2f} %")
            print(f"{name:16s} {w}x{h:<5d} " + "  ".join(line), flush=True)
        first = builds[0][0]
        print(f"{name}: {len(sizes)} sizes ({', '.join(sizes)})")
        for label, _, _ in builds:
            wins = sum(e < f for e, f in zip(errors[label], errors[first]))
            versus = "" if label == first else f", under {first}'s at {wins} of {len(sizes)}"
            print(f"  {label:12s} mean error {statistics.mean(errors[label]):6.2f} % "
                  f"(range {min(errors[label]):.2f}-{max(errors[label]):.2f}), "
                  f"mean wall {statistics.mean(walls[label]):5.2f} s{versus}", flush=True)


if __name__ == "__main__":
    main()
