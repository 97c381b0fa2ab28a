"""Error/time fronts of radsplat on a real GPU against rpict, from the files a device run of
`benches/device/sponza_h200.sh` brings back (see README.md here).

Usage: fronts_h200.py RESULTS.txt STATS_AND_COMPARE_DIR RPICT_LOCAL_DIR OUT.json PLOT.png
       [--prefix rs-] [--rpict-results OTHER_RESULTS.txt] [--noise cmp-refAB.json] [--title T]

RESULTS.txt: lines `label wall user sys` (radsplat `rs-<label>`, rpict `rpict-<label>`);
STATS_AND_COMPARE_DIR: `cmp-rs-<label>.json` (radsplat compare against the device's
reference A) and `cmp-refAB.json`; RPICT_LOCAL_DIR: `times.txt` (the same rpict runs timed
on this machine) and `cmp-<label>.json` (rpict's images, which do not depend on the machine,
against the device's reference A). Ratios at matched error as in fronts.py (log time of
rpict's front interpolated linearly in error).
"""
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "peers"))
from fronts import pareto, time_at_error  # noqa: E402


def read_times(path, prefix):
    out = {}
    for line in Path(path).read_text().splitlines():
        p = line.split()
        if len(p) == 4 and p[0].startswith(prefix):
            out.setdefault(p[0][len(prefix):], []).append((float(p[1]), float(p[2]) + float(p[3])))
    return {k: (sorted(w for w, _ in v)[len(v) // 2], sorted(c for _, c in v)[len(v) // 2])
            for k, v in out.items()}


def main():
    import argparse
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", help="the device run's results.txt")
    ap.add_argument("cmpdir", type=Path, help="cmp-<prefix><label>.json of radsplat's images")
    ap.add_argument("rpdir", type=Path, help="times.txt and cmp-<label>.json of rpict, here")
    ap.add_argument("out_json")
    ap.add_argument("plot_path")
    ap.add_argument("--prefix", default="rs-", help="radsplat's labels in RESULTS (rs-)")
    ap.add_argument("--rpict-results", default=None,
                    help="rpict's device times from this file (default RESULTS; none there: "
                         "rpict timed here only)")
    ap.add_argument("--noise", type=Path, default=None,
                    help="compare JSON of reference B against A (default CMPDIR/cmp-refAB.json)")
    ap.add_argument("--title", default="Sponza sun 1000x1000")
    ap.add_argument("--ymax", type=float, default=35.0)
    args = ap.parse_args()
    cmpdir, rpdir = args.cmpdir, args.rpdir
    out_json, plot_path = args.out_json, args.plot_path
    rs = read_times(args.results, args.prefix)
    rp_dev = read_times(args.rpict_results or args.results, "rpict-")
    rp_loc = read_times(rpdir / "times.txt", "rpict-")
    ab = json.loads((args.noise or cmpdir / "cmp-refAB.json").read_text())
    noise = ab["indirect"]["relative_rmse"] / math.sqrt(2)
    rad = [{"label": k, "wall_s": w, "cpu_s": c,
            "error": json.loads((cmpdir / f"cmp-{args.prefix}{k}.json").read_text())["indirect"]["relative_rmse"]}
           for k, (w, c) in rs.items()]
    rp = []
    for k in rp_loc:
        if k == "ab0":
            continue
        e = json.loads((rpdir / f"cmp-{k}.json").read_text())["indirect"]["relative_rmse"]
        dev = rp_dev.get(k, (None, None))
        rp.append({"label": k, "error": e, "wall_s": dev[0], "cpu_s": dev[1],
                   "local_wall_s": rp_loc[k][0], "local_cpu_s": rp_loc[k][1]})
    timings = ("device", "local") if all(p["wall_s"] is not None for p in rp) else ("local",)
    rad_front = pareto(rad)
    rows = []
    for timing in timings:
        pts = [dict(p, wall_s=p["wall_s"] if timing == "device" else p["local_wall_s"],
                    cpu_s=p["cpu_s"] if timing == "device" else p["local_cpu_s"]) for p in rp]
        front = pareto(pts)
        for p in sorted(rad, key=lambda p: p["wall_s"]):
            tw, tc = time_at_error(front, p["error"], "wall_s"), time_at_error(front, p["error"], "cpu_s")
            on = p in rad_front
            rows.append({"rpict_timing": timing, "radsplat": p["label"], "error": p["error"],
                         "on_front": on, "wall_ratio": tw / p["wall_s"] if tw else None,
                         "cpu_ratio": tc / p["cpu_s"] if tc else None})
        # Read the other way: at each rpict point, radsplat's front interpolated, or where
        # the error is above radsplat's front, the least time of a radsplat point that errs
        # no more (its time to reach at most that error: no interpolation in its favour).
        for q in front:
            tw = time_at_error(rad_front, q["error"], "wall_s")
            tc = time_at_error(rad_front, q["error"], "cpu_s")
            if tw is None:
                reach = [p for p in rad if p["error"] <= q["error"]]
                if reach:
                    tw = min(p["wall_s"] for p in reach)
                    tc = min(p["cpu_s"] for p in reach)
            rows.append({"rpict_timing": timing, "rpict": q["label"], "error": q["error"],
                         "wall_ratio": q["wall_s"] / tw if tw else None,
                         "cpu_ratio": q["cpu_s"] / tc if tc else None})
    print(f"reference noise {100 * noise:.3f} %")
    for p in sorted(rad, key=lambda p: p["wall_s"]):
        print(f"radsplat {p['label']:20s} {p['wall_s']:6.2f} s wall {p['cpu_s']:6.2f} s CPU "
              f"{100 * p['error']:6.2f} %{'' if p in rad_front else '  (off the front)'}")
    for p in rp:
        there = (f"{p['wall_s']:6.2f} s wall {p['cpu_s']:6.2f} s CPU " if p["wall_s"] is not None
                 else "")
        print(f"rpict    {p['label']:20s} {there}(here {p['local_wall_s']:6.2f} / "
              f"{p['local_cpu_s']:6.2f}) {100 * p['error']:6.2f} %")
    for r in rows:
        if r["wall_ratio"] is None:
            continue
        who = r.get("radsplat") or f"rpict {r['rpict']}"
        print(f"  rpict timed {r['rpict_timing']:6s} at {who:22s} {100 * r['error']:6.2f} %: "
              f"{r['wall_ratio']:6.2f}x wall, {r['cpu_ratio']:6.2f}x CPU")
    # The defaults pair (issue 17 item 6): faster and no less accurate.
    pair = None
    rd = next((p for p in rad if p["label"] == "defaults"), None)
    qd = next((p for p in rp if p["label"] == "defaults"), None)
    if rd and qd:
        wall = qd["wall_s"] if qd["wall_s"] is not None else qd["local_wall_s"]
        pair = {"speed": wall / rd["wall_s"], "error_ratio": rd["error"] / qd["error"]}
        ok = pair["speed"] > 1 and pair["error_ratio"] <= 1
        print(f"defaults pair: radsplat {rd['wall_s']:.2f} s at {100 * rd['error']:.2f} %, rpict "
              f"{wall:.2f} s at {100 * qd['error']:.2f} %: {pair['speed']:.2f}x faster, error "
              f"ratio {pair['error_ratio']:.3f} -> {'PASS' if ok else 'FAIL'}")
    Path(out_json).write_text(json.dumps({"noise": noise, "radsplat": rad, "rpict": rp,
                                          "ratios": rows, "defaults_pair": pair}, indent=1))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5), dpi=110)
    series = [(rad, "wall_s", "tab:blue", "radsplat on the H200")]
    if "device" in timings:
        series.append((rp, "wall_s", "tab:orange", "rpict -ab 1, the H200 machine's CPU"))
    series.append((rp, "local_wall_s", "tab:red", "rpict -ab 1, this machine's CPU"))
    for pts, key, colour, name in series:
        pts2 = [dict(p, wall_s=p[key]) for p in pts]
        front = pareto(pts2)
        ax.scatter([p["wall_s"] for p in pts2], [100 * p["error"] for p in pts2], color=colour, alpha=0.35, s=22)
        ax.plot([p["wall_s"] for p in front], [100 * p["error"] for p in front], "o-", color=colour, label=name)
        if colour != "tab:red" or len(series) == 2:
            for p in pts2:
                ax.annotate(p["label"], (p["wall_s"], 100 * p["error"]), fontsize=7, xytext=(4, 3),
                            textcoords="offset points", color=colour)
    ax.set_xscale("log")
    ax.set_ylim(0, args.ymax)
    ax.set_xlabel("wall time, s (log)")
    ax.set_ylabel("indirect relative RMSE, 4x4 box filter, %")
    ax.set_title(f"{args.title}: radsplat on an NVIDIA H200 against rpict\n"
                 f"(reference rendered on the H200, its noise {100 * noise:.2f} %)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(plot_path)


if __name__ == "__main__":
    main()
