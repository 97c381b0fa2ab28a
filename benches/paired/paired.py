#!/usr/bin/env python3
"""Paired timing of two radsplat builds on one scene (docs/results.md, stop 53).

This machine's lavapipe speed swings by 20-30 % within minutes, so medians of runs taken
minutes apart compare the machine, not the builds. This runs the two binaries
alternately, N times each, with `--stats` (and `--time-passes` unless `--untimed`, which
measures the process as users run it). Each run is compared with its neighbour: the
ratio B / A of the GPU time of the named passes and of the frame. It prints the median
ratio with its distribution-free 95 % interval (the sign test's order statistics; from 6
pairs) and whether that interval lies below 1, above 1 or includes it, the pairs under 1,
every pair's ratio, and checks that both builds wrote the same image bytes. On this
machine 10-pair medians of one change have read 1.12 and 0.94 in one session (stop 63):
read the interval, not the median.

    python3 benches/paired/paired.py OLD_BINARY NEW_BINARY scenes/nave.toml --runs 8 \
        [--passes "hemisphere planes,plane refinement" | --untimed] [-- extra render flags]

Standard library only; needs RADSPLAT_ASSET_PATH for scenes outside the repository.
"""
import argparse
import hashlib
import math
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


_TAKES_TIME_PASSES = {}


def takes_time_passes(binary):
    """Whether `binary render` has --time-passes (binaries before it always timed)."""
    key = str(binary)
    if key not in _TAKES_TIME_PASSES:
        help_text = subprocess.run([key, "render", "--help"], capture_output=True,
                                   text=True).stdout
        _TAKES_TIME_PASSES[key] = "--time-passes" in help_text
    return _TAKES_TIME_PASSES[key]


def run(binary, scene, out_dir, tag, extra, timed=True):
    image = out_dir / f"{tag}.exr"
    stats = out_dir / f"{tag}.json"
    t0 = time.perf_counter()
    # --time-passes: the passes' times are what this script compares (both binaries pay
    # for the timestamps alike; a binary from before the flag existed times them anyway).
    timing = ["--time-passes"] if timed and takes_time_passes(binary) else []
    subprocess.run([str(binary), "render", str(scene), "-o", str(image), "--quiet",
                    "--stats", str(stats), *timing, *extra], check=True)
    wall = time.perf_counter() - t0
    stats = json.loads(stats.read_text())
    frame = stats["frame"]
    start = dict(stats["command_ms"]).get("wait for GPU start", 0.0)
    digest = hashlib.sha256(image.read_bytes()).hexdigest()
    return dict(frame["pass_ms"]), frame["wall_ms"], wall, digest, start


def median_interval(xs, level=0.95):
    """Distribution-free confidence interval of the median of `xs` (the sign test's order
    statistics: [x_(k), x_(n+1-k)] with the largest k whose binomial tail P(B(n, 1/2) < k)
    is at most (1 - level) / 2), and its actual coverage. None below 6 values, where even
    [min, max] covers under 95 %."""
    n = len(xs)
    xs = sorted(xs)
    tail, k = 0.0, 0
    while True:
        p = math.comb(n, k) / 2 ** n
        if tail + p > (1 - level) / 2:
            break
        tail += p
        k += 1
    if k == 0:
        return None
    return xs[k - 1], xs[n - k], 1 - 2 * tail


def summary(xs):
    """The median, its 95 % interval and how many pairs fell below 1."""
    text = f"{statistics.median(xs):.3f}"
    ci = median_interval(xs)
    if ci:
        lo, hi, cover = ci
        verdict = "below 1" if hi < 1 else "above 1" if lo > 1 else "includes 1"
        text += f" [{lo:.3f}, {hi:.3f}] ({100 * cover:.1f} % interval, {verdict})"
    below = sum(1 for x in xs if x < 1)
    return text + f", {below} of {len(xs)} pairs under 1"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 epilog="Flags after -- go to both renders.")
    ap.add_argument("a", type=Path, help="the old build (the denominator)")
    ap.add_argument("b", type=Path, help="the new build")
    ap.add_argument("scene", type=Path)
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--untimed", action="store_true",
                    help="render without --time-passes, as users run it (no pass ratio; "
                         "a binary from before the flag still times its passes)")
    ap.add_argument("--passes", default="hemisphere planes,plane refinement",
                    help="comma-separated pass names of --stats' pass_ms, summed (a pass "
                         "one build has and the other lacks counts 0 there)")
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    args = ap.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    args.extra = extra
    names = [p.strip() for p in args.passes.split(",") if p.strip()]
    passes, frames, walls, starts, digests = [], [], [], [], set()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for i in range(args.runs):
            # Alternate which build runs first, so that neither always follows the other.
            order = ("a", "b") if i % 2 == 0 else ("b", "a")
            got = {}
            for side in order:
                binary = args.a if side == "a" else args.b
                got[side] = run(binary, args.scene, out, f"{side}{i}", args.extra,
                                not args.untimed)
            (pa, fa, wa, da, sa), (pb, fb, wb, db, sb) = got["a"], got["b"]
            missing = [n for n in names if n not in pa and n not in pb]
            if missing and not args.untimed:
                sys.exit(f"no pass named {missing} in --stats (have: {sorted(pa)})")
            old = sum(pa.get(n, 0.0) for n in names)
            # A build without GPU timestamps reports no pass times: no ratio then.
            passes.append(sum(pb.get(n, 0.0) for n in names) / old if old > 0 else 1.0)
            frames.append(fb / fa)
            walls.append(wb / wa)
            starts.append(sb / sa if sa > 0 else 1.0)
            digests.update((da, db))
    fmt = lambda xs: " ".join(f"{x:.2f}" for x in xs)
    print(f"{args.scene}, {args.runs} pairs, ratio new / old: the median, its 95 % "
          "interval (sign test), pairs under 1; then every pair")
    rows = [("start-up", starts), ("frame (GPU wall)", frames), ("process wall", walls)]
    if not args.untimed:
        rows.insert(0, (' + '.join(names), passes))
    for label, xs in rows:
        print(f"  {label + ':':18s} {summary(xs)}")
        print(f"  {'':18s} ({fmt(xs)})")
    print("  images: " + ("the same bytes" if len(digests) == 1 else
                          f"DIFFER ({len(digests)} distinct)"))


if __name__ == "__main__":
    main()
