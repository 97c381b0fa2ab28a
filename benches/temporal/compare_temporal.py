#!/usr/bin/env python3
"""Temporal radiance caching against per-frame recomputation (issue 4's measurement).

For one animated scene: renders frames A..B with `radsplat animate --temporal on` and
`--temporal off` (same cache settings), a brute-force reference per frame
(`radsplat reference --frame t`), then `radsplat compare-seq` of both against the
reference. Prints wall time, speedup, records computed, relative RMSE and flicker, and
the records computed per frame after the first against their bound: the harmonic mean
of the true lifespans of the records a frame places (`radsplat temporal-error --sites
placed` at the middle frame; what a perfect, free E(t+1) estimate would reach), when
the frames span at least twice dt_max.

    python3 benches/temporal/compare_temporal.py scenes/cube-in-box-anim.toml \\
        --frames 0..59 --size 64x64 --spp 64 [--max-lifespan 20] [--out out/temporal/NAME]

A short warm-up run first fills Mesa's on-disk shader cache: the first run of a new
binary compiles its shaders (seconds on lavapipe), which would otherwise be billed to
whichever variant runs first.
"""
import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd, cpu=None):
    """Runs cmd; returns its wall seconds. With `cpu` (a dict), also stores its CPU
    seconds (user + system, all threads) there: on a shared virtual machine the
    hypervisor may take a third of the time away (vmstat's `st`), which wall time counts
    and CPU time does not."""
    print("  $", " ".join(map(str, cmd)), file=sys.stderr)
    t0, c0 = time.perf_counter(), cpu_children()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(map(str, cmd))}\n{p.stderr}")
    if cpu is not None:
        cpu["cpu_s"] = cpu_children() - c0
    return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", type=Path)
    ap.add_argument("--frames", default="0..59")
    ap.add_argument("--size", default="64x64")
    ap.add_argument("--spp", type=int, default=64, help="reference bounce samples per pixel")
    ap.add_argument("--accuracy", default="0.2")
    ap.add_argument("--plane-resolution", default="32")
    ap.add_argument("--temporal-accuracy", default=None,
                    help="a_t (default: the scene's [animation].temporal_accuracy, else 0.05)")
    ap.add_argument("--max-lifespan", default=None,
                    help="dt_max (default: the scene's [animation].max_lifespan, else 20)")
    ap.add_argument("--record-anchor", default="world", choices=["world", "instance"],
                    help="where temporal records stay while objects move")
    ap.add_argument("--estimate-stride", default=None,
                    help="animate --estimate-stride for the temporal run (default: radsplat's)")
    ap.add_argument("--modes", default="off,on", help="which of off,on to run")
    ap.add_argument("--ref-dir", type=Path, default=None,
                    help="where the per-frame references are (made there if missing)")
    ap.add_argument("--radsplat", type=Path, default=REPO / "target/release/radsplat")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--no-reference", action="store_true",
                    help="timings and records only (no reference, RMSE or flicker)")
    ap.add_argument("--no-bound", action="store_true",
                    help="skip the records-computed bound (temporal-error --sites placed)")
    args = ap.parse_args()
    out = (args.out or REPO / "out/temporal" / args.scene.stem).resolve()
    out.mkdir(parents=True, exist_ok=True)
    a, b = (int(v) for v in args.frames.split(".."))
    rs = args.radsplat.resolve()
    common = ["--size", args.size, "-a", args.accuracy, "--plane-resolution",
              args.plane_resolution, "--quiet"]
    # Long enough for replacements, so that the plane refresh passes are compiled too.
    run([rs, "animate", args.scene, "--frames", f"{a}..{min(a + 4, b)}", "-o",
         out / "warmup_####.exr"] + common)
    rows = {}
    modes = [m for m in ("off", "on") if m in args.modes.split(",")]
    refs = (args.ref_dir or out).resolve()
    refs.mkdir(parents=True, exist_ok=True)
    for mode in modes:
        extra = [] if mode == "off" else (
            (["--temporal-accuracy", args.temporal_accuracy] if args.temporal_accuracy else [])
            + (["--max-lifespan", args.max_lifespan] if args.max_lifespan else [])
            + (["--estimate-stride", args.estimate_stride] if args.estimate_stride else []) + [
            "--record-anchor", args.record_anchor,
            "--lifespan-map", out / "lifespan_####.png"])
        cpu = {}
        wall = run([rs, "animate", args.scene, "--frames", f"{a}..{b}", "--temporal", mode,
                    "-o", out / f"{mode}_####.exr", "--stats", out / f"{mode}.json"]
                   + common + extra, cpu)
        stats = json.loads((out / f"{mode}.json").read_text())
        per_frame = [f["temporal"]["replaced"] + f["temporal"]["new"] for f in stats["frames"]]
        if mode == "on":
            dt_max = stats["temporal"]["max_lifespan"]
        rows[mode] = {"wall_s": wall, "cpu_s": cpu["cpu_s"],
                      "records_computed": stats["records_computed"],
                      "records_per_frame": per_frame,
                      "plane_rays": stats["plane_rays"],
                      "peak_alive": max(f["temporal"]["alive"] for f in stats["frames"])}
    if not args.no_reference:
        t0 = time.perf_counter()
        for t in range(a, b + 1):
            ref = refs / f"ref_{t:04d}.exr"
            if not ref.exists():
                run([rs, "reference", args.scene, "--frame", t, "--spp", args.spp, "--size",
                     args.size, "-o", ref, "--quiet"])
        ref_wall = time.perf_counter() - t0
        for mode in modes:
            run([rs, "compare-seq", out / f"{mode}_####.exr", refs / "ref_####.exr", "--frames",
                 f"{a}..{b}", "--json", out / f"{mode}-vs-ref.json", "--plot",
                 out / f"{mode}-vs-ref.png"])
            c = json.loads((out / f"{mode}-vs-ref.json").read_text())["summary"]
            rows[mode].update({"mean_relative_rmse": c["mean_relative_rmse"],
                               "mean_flicker_relative": c["mean_flicker_relative"]})
    both = "off" in rows and "on" in rows
    bound = None
    # temporal-error takes a_t and dt_max from the scene, so only without overrides.
    if (both and not args.no_bound and b - a >= 2 * dt_max
            and not (args.temporal_accuracy or args.max_lifespan)):
        mid = (a + b) // 2
        extra = (["--estimate-stride", args.estimate_stride] if args.estimate_stride else [])
        run([rs, "temporal-error", args.scene, "--frame", mid, "--sites", "placed",
             "--record-count", 1000000, "--size", args.size, "-a", args.accuracy,
             "--plane-resolution", args.plane_resolution, "--record-anchor",
             args.record_anchor, "--json", out / "bound.json"] + extra)
        lifespans = json.loads((out / "bound.json").read_text())["lifespans"]
        bound = {"frame": mid, "true_harmonic": lifespans["true_harmonic"],
                 "estimated_harmonic": lifespans["estimated_harmonic"]}
    speedup = rows["off"]["wall_s"] / rows["on"]["wall_s"] if both else None
    cpu_speedup = rows["off"]["cpu_s"] / rows["on"]["cpu_s"] if both else None
    print(f"\n{args.scene} frames {a}..{b} at {args.size}, a = {args.accuracy}, "
          f"P = {args.plane_resolution}, a_t = {args.temporal_accuracy or 'scene'}, "
          f"dt_max = {args.max_lifespan or 'scene'}, records anchored to the {args.record_anchor}")
    print(f"{'':<10} {'wall s':>8} {'CPU s':>8} {'records':>9} {'peak alive':>10} {'rel RMSE':>9} "
          f"{'flicker':>8}")
    for mode in modes:
        r = rows[mode]
        rm = r.get("mean_relative_rmse")
        fl = r.get("mean_flicker_relative")
        print(f"{'temporal ' + mode:<10} {r['wall_s']:>8.1f} {r['cpu_s']:>8.1f} "
              f"{r['records_computed']:>9} "
              f"{r['peak_alive']:>10} "
              f"{'-' if rm is None else f'{100 * rm:.2f}%':>9} "
              f"{'-' if fl is None else f'{100 * fl:.3f}%':>8}")
    if speedup is not None:
        print(f"speedup {speedup:.2f}x (CPU time {cpu_speedup:.2f}x), records computed "
              f"{rows['off']['records_computed']} -> {rows['on']['records_computed']}")
    # The steady state: from dt_max frames on, when the first frame's records have expired
    # (before that, temporal caching computes fewer records than any steady state can).
    steady = (rows["on"]["records_per_frame"][dt_max:] if both else [])
    if steady and sum(steady) > 0:
        reached = sum(rows["off"]["records_per_frame"][dt_max:]) / sum(steady)
        line = (f"records computed per frame from frame {a + dt_max} on (steady state): "
                f"{reached:.2f}x fewer")
        if bound is not None:
            line += (f"; bound at frame {bound['frame']} (true lifespans of a frame's "
                     f"records, harmonic mean): {bound['true_harmonic']:.2f}x "
                     f"({100 * reached / bound['true_harmonic']:.0f} % of it)")
            bound["reached"] = reached
        print(line)
    summary = {"scene": str(args.scene), "frames": [a, b], "size": args.size,
               "accuracy": args.accuracy, "plane_resolution": args.plane_resolution,
               "temporal_accuracy": args.temporal_accuracy, "max_lifespan": args.max_lifespan,
               "record_anchor": args.record_anchor, "estimate_stride": args.estimate_stride,
               "spp": args.spp, "rows": rows, "speedup": speedup,
               "cpu_speedup": cpu_speedup, "bound": bound}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {out / 'summary.json'}")


if __name__ == "__main__":
    main()
