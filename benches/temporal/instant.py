#!/usr/bin/env python3
"""Temporal instant caching (`animate --records vpl`, seed 003) against temporal radiance
caching (`--records planes`) and per-frame recomputation of each (`--temporal off`), on
one animated scene: wall and CPU time, speedup over per-frame recomputation, mean
relative RMSE and flicker against per-frame path-traced references (`radsplat reference
--frame t`, made once into --ref-dir and reused), and the rays temporal instant caching
traced again against those it reused.

    python3 benches/temporal/instant.py scenes/cube-in-box-anim.toml --frames 0..23 \\
        --size 48x48 --spp 256 --ref-dir out/refs/cube [--planes-flags "--plane-resolution 16"]
"""
import argparse
import json
import resource
import shlex
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd):
    print("  $", " ".join(map(str, cmd)), file=sys.stderr)
    t0, c0 = time.perf_counter(), cpu_children()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(map(str, cmd))}\n{p.stderr}")
    return time.perf_counter() - t0, cpu_children() - c0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", type=Path)
    ap.add_argument("--frames", default="0..23")
    ap.add_argument("--size", default="48x48")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--ref-dir", type=Path, required=True)
    ap.add_argument("--planes-flags", default="", help="extra flags of the plane runs")
    ap.add_argument("--vpl-flags", default="", help="extra flags of the VPL runs")
    ap.add_argument("--radsplat", type=Path, default=REPO / "target/release/radsplat")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    out = (args.out or REPO / "out/instant" / args.scene.stem).resolve()
    out.mkdir(parents=True, exist_ok=True)
    a, b = (int(v) for v in args.frames.split(".."))
    rs = args.radsplat.resolve()
    refs = args.ref_dir.resolve()
    refs.mkdir(parents=True, exist_ok=True)
    for t in range(a, b + 1):
        ref = refs / f"ref_{t:04d}.exr"
        if not ref.exists():
            run([rs, "reference", args.scene, "--frame", t, "--spp", args.spp, "--size",
                 args.size, "-o", ref, "--quiet"])
    variants = [
        ("planes, temporal", ["--records", "planes", "--temporal", "on"], args.planes_flags),
        ("planes, per frame", ["--records", "planes", "--temporal", "off"], args.planes_flags),
        ("vpl, temporal", ["--records", "vpl", "--temporal", "on"], args.vpl_flags),
        ("vpl, per frame", ["--records", "vpl", "--temporal", "off"], args.vpl_flags),
    ]
    common = ["--size", args.size, "--quiet"]
    # Warm Mesa's shader cache for every pass first.
    for _, flags, extra in variants:
        run([rs, "animate", args.scene, "--frames", f"{a}..{min(a + 2, b)}", "-o",
             out / "warmup_####.exr"] + common + flags + shlex.split(extra))
    rows = []
    for name, flags, extra in variants:
        tag = name.replace(", ", "-").replace(" ", "-")
        wall, cpu = run([rs, "animate", args.scene, "--frames", f"{a}..{b}", "-o",
                         out / f"{tag}_####.exr", "--stats", out / f"{tag}.json"]
                        + common + flags + shlex.split(extra))
        run([rs, "compare-seq", out / f"{tag}_####.exr", refs / "ref_####.exr", "--frames",
             f"{a}..{b}", "--json", out / f"{tag}-vs-ref.json"])
        c = json.loads((out / f"{tag}-vs-ref.json").read_text())["summary"]
        stats = json.loads((out / f"{tag}.json").read_text())
        traced = sum((f["temporal"].get("instant") or {}).get("traced_rays", 0)
                     for f in stats["frames"])
        reused = sum((f["temporal"].get("instant") or {}).get("reused_rays", 0)
                     for f in stats["frames"])
        rows.append({"variant": name, "flags": flags + shlex.split(extra), "wall_s": wall,
                     "cpu_s": cpu, "rmse": c["mean_relative_rmse"],
                     "flicker": c["mean_flicker_relative"], "records_computed":
                     stats["records_computed"], "update_rays_traced": traced,
                     "update_rays_reused": reused})
    print(f"\n{args.scene} frames {a}..{b} at {args.size}, references {args.spp} spp")
    print(f"{'variant':<18} {'wall s':>7} {'CPU s':>7} {'speedup':>8} {'rel RMSE':>9} "
          f"{'flicker':>8} {'records':>8}")
    for r in rows:
        base = next(x for x in rows if x["variant"] == r["variant"].split(",")[0] + ", per frame")
        r["speedup"] = base["wall_s"] / r["wall_s"]
        print(f"{r['variant']:<18} {r['wall_s']:>7.1f} {r['cpu_s']:>7.1f} {r['speedup']:>7.2f}x "
              f"{100 * r['rmse']:>8.2f}% {100 * r['flicker']:>7.3f}% {r['records_computed']:>8}")
    tic = next(r for r in rows if r["variant"] == "vpl, temporal")
    if tic["update_rays_traced"] + tic["update_rays_reused"] > 0:
        share = tic["update_rays_traced"] / (tic["update_rays_traced"] + tic["update_rays_reused"])
        print(f"temporal instant caching traced {100 * share:.1f} % of its kept records' rays again")
    (out / "summary.json").write_text(json.dumps(rows, indent=2))
    print(f"wrote {out / 'summary.json'}")


if __name__ == "__main__":
    main()
