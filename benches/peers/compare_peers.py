#!/usr/bin/env python3
"""Side-by-side comparison of radsplat with Radiance's rpict (see README.md here).

Steps (all outputs under --out, default out/peers/<scene>):
  1. `radsplat export-rad`: the scene as Radiance (scene.rad, view.vf) and a radsplat scene
     variant without textures (notex.toml), so both renderers see the same Kd colours.
  2. radsplat: direct-only render, GI render at accuracy -a (if this build has it), and the
     brute-force reference (`radsplat reference --spp N`), all from notex.toml.
  3. rpict (pyradiance's bundled binaries): -ab 0 (direct only) and -ab 1 with -aa/-ad/-as
     and an ambient file, whose records are counted with lookamb.
  4. Every image is compared with the reference by `radsplat compare`; the table prints wall
     time, irradiance records and (relative) RMSE. The direct-only pair validates the
     conversion: rpict -ab 0 vs radsplat's direct-only image should agree within a few %.

Units: Radiance pictures hold radiance in W/(sr m^2) per channel (rpict writes no EXPOSURE;
`radsplat compare` divides one out if present), the unit of radsplat's EXR files.
"""

import argparse
import json
import resource
import os
import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def radiance_dirs():
    """bin and lib directories of the pyradiance wheel (rpict, oconv, lookamb, rayinit.cal)."""
    try:
        import pyradiance
    except ImportError:
        sys.exit("pyradiance is not installed: run benches/peers/run.sh (it makes a venv)")
    root = Path(pyradiance.__file__).resolve().parent
    return root / "bin", root / "lib"


def peer_env(radsplat):
    """The environment both renderers run in (Radiance's binaries on PATH, its RAYPATH), the
    resolved radsplat binary (exits if it is missing) and Radiance's bin directory."""
    bindir, libdir = radiance_dirs()
    env = dict(os.environ)
    env["RAYPATH"] = f".:{libdir}"
    env["PATH"] = f"{bindir}:{env.get('PATH', '')}"
    radsplat = radsplat.resolve()
    if not radsplat.exists():
        sys.exit(f"{radsplat} not found: run `cargo build --release` first")
    return env, radsplat, bindir


# CPU seconds (user + system) of the last command run: rpict is single-threaded, so its CPU
# time does not depend on what else the machine runs; radsplat's lavapipe uses every core.
LAST_CPU = [0.0]


def run(cmd, env, stdout=None, quiet=False):
    """Runs a command, returns its wall time in seconds; exits with its stderr on failure."""
    if not quiet:
        print("  $", " ".join(str(c) for c in cmd), file=sys.stderr)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], env=env, stdout=stdout or subprocess.PIPE,
                       stderr=subprocess.PIPE)
    dt = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    LAST_CPU[0] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n"
                 f"{p.stderr.decode(errors='replace')}")
    return dt, (p.stdout.decode(errors="replace") if stdout is None else "")


def compare(radsplat, a, ref, out, env, downsample=1, minus=None):
    """`radsplat compare A REF --json [--downsample N] [--minus C]`, returns the parsed JSON."""
    stem = Path(a).stem + ("-minus-" + Path(minus).stem if minus else "")
    js = out / (stem + "-vs-ref.json")
    run([radsplat, "compare", a, ref, "--json", js, "--diff", out / (stem + "-diff.png"),
         "--downsample", str(downsample)] + (["--minus", minus] if minus else []),
        env, quiet=True)
    return json.loads(js.read_text())


def count_ambient_records(bindir, amb, env):
    """Number of records in a Radiance ambient file (lookamb prints one block per record,
    each starting with its position line)."""
    if not amb.exists():
        return 0
    _, text = run([bindir / "lookamb", amb], env, quiet=True)
    return sum(1 for line in text.splitlines() if re.match(r"\s*Position:", line))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--size", default="128x128", help="WxH for every renderer")
    ap.add_argument("--accuracy", "-a", type=float, default=0.15,
                    help="irradiance-cache accuracy: rpict -aa and radsplat render -a")
    ap.add_argument("--ad", type=int, default=1024, help="rpict -ad (hemisphere divisions)")
    ap.add_argument("--as", dest="as_", type=int, default=512, help="rpict -as (super-samples)")
    ap.add_argument("--ar", type=int, default=128, help="rpict -ar (ambient resolution)")
    ap.add_argument("--ds", type=float, default=0.05,
                    help="rpict -ds (area-light subdivision; smaller is finer)")
    ap.add_argument("--dj", type=float, default=0.7,
                    help="rpict -dj (source jitter; 0 samples each source at fixed points, "
                         "e.g. a sun as radsplat's delta sun)")
    ap.add_argument("--plane-resolution", type=int, default=32,
                    help="radsplat hemisphere plane P (P x P rays per record; 32 x 32 = 1024 "
                         "rays, the same count as rpict -ad 1024)")
    ap.add_argument("--reference", type=Path, default=None,
                    help="reuse this radsplat reference EXR (rendered with `radsplat reference` "
                         "on OUT/rad/notex.toml at the same size) instead of rendering one")
    ap.add_argument("--downsample", type=int, default=1,
                    help="compare after box-filtering every image N x N (averages out the "
                         "reference's Monte Carlo noise at large sizes)")
    ap.add_argument("--spp", type=int, default=256, help="radsplat reference bounce samples")
    ap.add_argument("--light-samples", type=int, default=16,
                    help="radsplat light samples per area light")
    ap.add_argument("--radsplat", type=Path, default=REPO / "target/release/radsplat")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()

    env, radsplat, bindir = peer_env(args.radsplat)
    w, h = (int(v) for v in args.size.lower().split("x"))
    out = (args.out or REPO / "out/peers" / args.scene.stem).resolve()
    out.mkdir(parents=True, exist_ok=True)

    print(f"== {args.scene} at {w}x{h}, output in {out}", file=sys.stderr)
    run([radsplat, "export-rad", args.scene, out / "rad", "--size", args.size], env)
    info = json.loads((out / "rad/export.json").read_text())
    notex = out / "rad/notex.toml"
    view = info["view"].split()
    run([bindir / "oconv", out / "rad/scene.rad"], env, stdout=open(out / "scene.oct", "wb"))

    rows = []  # (name, wall s, records, image)
    common = ["--size", args.size, "--light-samples", str(args.light_samples), "--quiet"]

    # radsplat reference first: everything is compared with it.
    if args.reference is None:
        ref = out / "radsplat-reference.exr"
        t, _ = run([radsplat, "reference", notex, "--spp", str(args.spp), "-o", ref,
                    "--stats", out / "reference-stats.json"] + common, env)
        rows.append((f"radsplat reference ({args.spp} spp)", t, None, ref, LAST_CPU[0]))
    else:
        ref = args.reference.resolve()

    # radsplat direct only (--direct-only), then irradiance-cache GI at accuracy -a.
    direct = out / "radsplat-direct.exr"
    t, _ = run([radsplat, "render", notex, "--direct-only", "-o", direct, "--stats", out / "direct-stats.json"]
               + common, env)
    rows.append(("radsplat direct only", t, None, direct, LAST_CPU[0]))
    _, help_text = run([radsplat, "render", "--help"], env, quiet=True)
    gi_pending = "--accuracy" not in help_text
    if not gi_pending:
        gi = out / "radsplat-gi.exr"
        stats = out / "gi-stats.json"
        t, _ = run([radsplat, "render", notex, "-a", str(args.accuracy), "-o", gi,
                    "--plane-resolution", str(args.plane_resolution),
                    "--stats", stats] + common, env)
        # radsplat render --stats: {"bvh": ..., "frame": {..., "cache": {"records": N, ...}}}
        records = json.loads(stats.read_text())["frame"]["cache"]["records"]
        rows.append((f"radsplat GI -a {args.accuracy}", t, records, gi, LAST_CPU[0]))

    # rpict: pixel centres (-pj 0), every pixel traced (-ps 1), exact size (-pa 0).
    rp = [bindir / "rpict"] + view + ["-x", w, "-y", h, "-pa", "0", "-pj", "0", "-ps", "1",
                                      "-pt", "0", "-dt", "0", "-dc", "1", "-dj", str(args.dj),
                                      "-ds", args.ds, "-dr", "0", "-lr", "1"]
    rp_direct = out / "rpict-ab0.hdr"
    t, _ = run(rp + ["-ab", "0", out / "scene.oct"], env, stdout=open(rp_direct, "wb"))
    rows.append(("rpict -ab 0", t, None, rp_direct, LAST_CPU[0]))
    amb = out / "rpict.amb"
    if amb.exists():
        amb.unlink()
    rp_gi = out / "rpict-ab1.hdr"
    t, _ = run(rp + ["-ab", "1", "-aa", args.accuracy, "-ad", args.ad, "-as", args.as_,
                     "-ar", args.ar, "-af", amb, out / "scene.oct"],
               env, stdout=open(rp_gi, "wb"))
    cpu = LAST_CPU[0]
    rows.append((f"rpict -ab 1 -aa {args.accuracy}", t, count_ambient_records(bindir, amb, env),
                 rp_gi, cpu))

    results = []
    print()
    print(f"{'renderer':<32} {'wall s':>8} {'cpu s':>8} {'records':>8} {'RMSE':>10} {'rel RMSE':>9} "
          f"{'rel RMSE surfaces':>17} {'rel RMSE indirect':>17}")
    for name, t, records, img, cpu in rows:
        c = compare(radsplat, img, ref, out, env, args.downsample)
        b = c["beauty"]
        surf = c.get("surfaces") or {}
        indirect = c.get("indirect")
        if img == rp_gi:
            # rpict's indirect light: -ab 1 minus -ab 0 (same direct sampling).
            indirect = compare(radsplat, img, ref, out, env, args.downsample,
                               minus=rp_direct).get("indirect")
        results.append({"renderer": name, "wall_s": t, "cpu_s": cpu, "records": records,
                        "image": str(img), "beauty": b, "surfaces": surf or None,
                        "indirect": indirect})
        rec = "-" if records is None else str(records)
        ind = float("nan") if indirect is None else indirect["relative_rmse"]
        print(f"{name:<32} {t:>8.2f} {cpu:>8.2f} {rec:>8} {b['rmse']:>10.4g} {b['relative_rmse']:>9.4f} "
              f"{surf.get('relative_rmse', float('nan')):>17.4f} {ind:>17.4f}")
    if gi_pending:
        name = f"radsplat GI -a {args.accuracy}"
        print(f"{name:<32} pending: this build's render has no -a/--accuracy")

    # Conversion check: direct-only rpict vs direct-only radsplat.
    vc = compare(radsplat, rp_direct, direct, out, env)
    v, vs = vc["beauty"], vc.get("surfaces") or {}
    print(f"\nconversion check, rpict -ab 0 vs radsplat direct only: relative RMSE "
          f"{100 * v['relative_rmse']:.2f} % (surfaces only: "
          f"{100 * vs.get('relative_rmse', float('nan')):.2f} %)")
    if info.get("has_environment"):
        print("note: the scene has an environment; radsplat samples it as direct light, "
              "Radiance's glow sky is ambient-only, so -ab 0 and -ab 1 lack sky terms")
    summary = {"scene": str(args.scene), "width": w, "height": h, "accuracy": args.accuracy,
               "rpict": {"ad": args.ad, "as": args.as_, "ar": args.ar, "ds": args.ds, "dj": args.dj},
               "spp": args.spp, "reference": str(ref), "downsample": args.downsample,
               "plane_resolution": args.plane_resolution, "light_samples": args.light_samples,
               "gi_pending": gi_pending, "results": results,
               "conversion_check_relative_rmse": v["relative_rmse"],
               "conversion_check_relative_rmse_surfaces": vs.get("relative_rmse")}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {out / 'summary.json'}")


if __name__ == "__main__":
    main()
