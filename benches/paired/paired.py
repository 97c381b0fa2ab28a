#!/usr/bin/env python3
"""Paired timing of two radsplat builds on one scene (docs/results.md, stop 53).

This machine's lavapipe speed swings by 20-30 % within minutes, so medians of runs taken
minutes apart compare the machine, not the builds. This runs the two binaries
alternately, N times each, with `--stats`. Each run is compared with its neighbour: the
ratio B / A of the GPU time of the named passes and of the frame. It prints the median
ratio and every pair's, and checks that both builds wrote the same image bytes.

    python3 benches/paired/paired.py OLD_BINARY NEW_BINARY scenes/nave.toml --runs 8 \
        [--passes "hemisphere planes,plane refinement"] [-- extra render flags]

Standard library only; needs RADSPLAT_ASSET_PATH for scenes outside the repository.
"""
import argparse
import hashlib
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(binary, scene, out_dir, tag, extra):
    image = out_dir / f"{tag}.exr"
    stats = out_dir / f"{tag}.json"
    t0 = time.perf_counter()
    subprocess.run([str(binary), "render", str(scene), "-o", str(image), "--quiet",
                    "--stats", str(stats), *extra], check=True)
    wall = time.perf_counter() - t0
    stats = json.loads(stats.read_text())
    frame = stats["frame"]
    start = dict(stats["command_ms"]).get("wait for GPU start", 0.0)
    digest = hashlib.sha256(image.read_bytes()).hexdigest()
    return dict(frame["pass_ms"]), frame["wall_ms"], wall, digest, start


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 epilog="Flags after -- go to both renders.")
    ap.add_argument("a", type=Path, help="the old build (the denominator)")
    ap.add_argument("b", type=Path, help="the new build")
    ap.add_argument("scene", type=Path)
    ap.add_argument("--runs", type=int, default=8)
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
                got[side] = run(binary, args.scene, out, f"{side}{i}", args.extra)
            (pa, fa, wa, da, sa), (pb, fb, wb, db, sb) = got["a"], got["b"]
            missing = [n for n in names if n not in pa and n not in pb]
            if missing:
                sys.exit(f"no pass named {missing} in --stats (have: {sorted(pa)})")
            passes.append(sum(pb.get(n, 0.0) for n in names)
                          / sum(pa.get(n, 0.0) for n in names))
            frames.append(fb / fa)
            walls.append(wb / wa)
            starts.append(sb / sa if sa > 0 else 1.0)
            digests.update((da, db))
    fmt = lambda xs: " ".join(f"{x:.2f}" for x in xs)
    print(f"{args.scene}, {args.runs} pairs, ratio new / old (median; per pair)")
    print(f"  {' + '.join(names)}: {statistics.median(passes):.3f}  ({fmt(passes)})")
    print(f"  start-up:          {statistics.median(starts):.3f}  ({fmt(starts)})")
    print(f"  frame (GPU wall):  {statistics.median(frames):.3f}  ({fmt(frames)})")
    print(f"  process wall:      {statistics.median(walls):.3f}  ({fmt(walls)})")
    print("  images: " + ("the same bytes" if len(digests) == 1 else
                          f"DIFFER ({len(digests)} distinct)"))


if __name__ == "__main__":
    main()
