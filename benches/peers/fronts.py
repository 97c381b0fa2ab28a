#!/usr/bin/env python3
"""Error/time fronts of radsplat and Radiance's rpict on one scene (issue 17, item 1).

Both renderers run at several settings each (the defaults pair always included: `radsplat
render` without -a / --plane-resolution, and rpict with its own ambient defaults, `-ab 1`),
every image is compared with a brute-force reference, and the script prints:

  * the reference's own noise, from two references with different seeds (relative RMSE of
    their indirect light / sqrt(2)); it must be under a fifth of the smallest error compared,
    otherwise the run fails (exit 3) unless --allow-noisy;
  * each side's points and Pareto front (indirect relative RMSE against wall time; CPU time
    kept too);
  * the speed ratio at matched error for every radsplat point whose error lies in rpict's
    front's error range: log(time) of rpict's front interpolated linearly in error between
    the two bracketing front points, divided by radsplat's time (wall and CPU seconds);
  * the defaults pair: radsplat's defaults against rpict's defaults (faster and no less
    accurate, or not); with --pair-alternate N also timed in N alternating pairs (the
    median of the per-pair ratios), which this machine's drift between the two sides'
    points cannot bias.

The error is the relative RMSE of the indirect light after an N x N box filter (default 4):
radsplat's `indirect.*` AOV; rpict's `-ab 1` image minus its `-ab 0` image (`radsplat compare
--minus`), both against the reference's `indirect.*`. Outputs under --out (default
out/fronts/<scene>[-WxH]): images, per-point JSON (the cache), summary.json, fronts.txt, and the
plot (default docs/images/peers-<scene>.png).

Caching: every rendered point is kept as OUT/points/<side>-<label>.json with its command
line and a key (for radsplat: the binary's SHA-256 and notex.toml; for rpict: the
pyradiance version, scene.rad and the view); a rerun reuses every point whose key matches,
so a new radsplat build rerenders radsplat's points only. `--only radsplat` rerenders
radsplat's points even if cached and takes rpict's from the cache (never rendering them),
`--only rpict` the other way round; `--fresh` rerenders everything. References are cached by
scene, size, spp, seed, light samples and `REFERENCE_ESTIMATOR` (not by binary: the
reference pass is not what is measured, but a change of its estimator makes earlier
references stale); `--reference A.exr --reference2 B.exr` reuses given files.
"""

import argparse
import hashlib
import json
import math
import re
import statistics
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare_peers import (  # noqa: E402  (shared pieces of the single-setting comparison)
    LAST_CPU, REPO, count_ambient_records, peer_env, run)

# Settings per scene (the scene file's stem). Every list gets its side's defaults point
# added in front ("defaults": no cache flags); labels name the points in tables, files, plot.
# radsplat's defaults are CacheSettings::default() (-a 0.25, Hessian record radii, 24 x 24 planes;
# "split-sphere-a0.2" is the previous defaults); rpict's are -aa 0.2 -ad 512 -as 128
# -ar 64 (`rpict -defaults`). "spp": reference bounce samples per pixel; "dj": rpict's
# source jitter (0: fixed points on each source, as for a sun); "light_samples": radsplat's
# light samples (None: the scene file's); "ref_light_samples": the references' light samples
# (at the pixel and at every bounce hit; the estimate is unbiased at any count, and fewer
# shadow rays per bounce buy more bounce samples for the same time: on the Cornell box 1024
# spp with 2 light samples cost what 256 spp with 16 did, at half the noise); "size": the
# default --size (None: the scene's).
# rpict's points beside its defaults (which every scene runs too): two cheaper, two dearer,
# the same on every scene.
RPICT_POINTS = [
    ("aa0.4-ad128", ["-aa", "0.4", "-ad", "128", "-as", "64", "-ar", "16"]),
    ("aa0.3-ad256", ["-aa", "0.3", "-ad", "256", "-as", "128", "-ar", "32"]),
    ("aa0.15-ad768", ["-aa", "0.15", "-ad", "768", "-as", "384", "-ar", "96"]),
    ("aa0.1-ad1024", ["-aa", "0.1", "-ad", "1024", "-as", "512", "-ar", "128"]),
]
SETTINGS = {
    "cornell-box": {
        "spp": 4096, "dj": 0.7, "light_samples": None, "ref_light_samples": 2,
        "size": "128x128",
        "radsplat": [
            ("split-sphere-a0.2", ["--record-radius", "split-sphere", "-a", "0.2"]),
            ("a0.3-P16", ["-a", "0.3", "--plane-resolution", "16"]),
            ("a0.2-P32", ["-a", "0.2", "--plane-resolution", "32"]),
            ("a0.15-P32", ["-a", "0.15", "--plane-resolution", "32"]),
            ("a0.1-P32", ["-a", "0.1", "--plane-resolution", "32"]),
            ("a0.1-P48", ["-a", "0.1", "--plane-resolution", "48"]),
        ],
        "rpict": RPICT_POINTS,
    },
    # Issue 17's measurements at 1000x1000: rpict 22.7 % in 12.3 s (-aa 0.3 -ad 256 -as 128
    # -ar 32), 20.2 % in 32.1 s (defaults), 19.0 % in 90.5 s, 18.6 % in 194 s (-aa 0.1
    # -ad 1024); radsplat's front from 12 s (-a 0.5, 16 x 16 planes) to 190 s (-a 0.1).
    "sponza-sun": {
        "spp": 128, "dj": 0.0, "light_samples": None, "ref_light_samples": None,
        "size": "1000x1000",
        "radsplat": [
            ("split-sphere-a0.2", ["--record-radius", "split-sphere", "-a", "0.2"]),
            # The cheapest reach rpict's range of error (18-27 %), so that the ratio at
            # matched error can be read (stop 32; P 8 since the light-map lookup stopped
            # leaking, which took P 12 below that range, stop 46).
            ("a1.0-P8", ["-a", "1.0", "--plane-resolution", "8"]),
            ("a1.0-P12", ["-a", "1.0", "--plane-resolution", "12"]),
            ("a1.0-P16", ["-a", "1.0", "--plane-resolution", "16"]),
            ("a0.7-P12", ["-a", "0.7", "--plane-resolution", "12"]),
            ("a0.5-P16", ["-a", "0.5", "--plane-resolution", "16"]),
            ("a0.3-P16", ["-a", "0.3", "--plane-resolution", "16"]),
            ("a0.3-P24", ["-a", "0.3", "--plane-resolution", "24"]),
            ("a0.15-P24", ["-a", "0.15", "--plane-resolution", "24"]),
        ],
        "rpict": RPICT_POINTS,
    },
    # 160x120: rpict -ab 1 at its defaults takes ~16 CPU s at 80x60 on this scene (331k
    # triangles), so ~65 s here, its cheaper points 10-30 s, its dearest a few minutes.
    "conference": {
        "spp": 8192, "dj": 0.7, "light_samples": None, "ref_light_samples": 1,
        "size": "160x120",
        "radsplat": [
            ("split-sphere-a0.2", ["--record-radius", "split-sphere", "-a", "0.2"]),
            ("a0.5-P16", ["-a", "0.5", "--plane-resolution", "16"]),
            ("a0.3-P24", ["-a", "0.3", "--plane-resolution", "24"]),
            ("a0.15-P24", ["-a", "0.15", "--plane-resolution", "24"]),
            ("a0.15-P32", ["-a", "0.15", "--plane-resolution", "32"]),
            ("a0.1-P32", ["-a", "0.1", "--plane-resolution", "32"]),
        ],
        "rpict": RPICT_POINTS,
    },
    # Our own stand-in for issue 17's cathedral (scenes/nave.toml, 288 triangles): a hall lit
    # by a low sun through five small windows, nearly all of its light indirect and from a
    # few bright patches. Sun: rpict's source unjittered (-dj 0), as radsplat's delta sun.
    "nave": {
        "spp": 4096, "dj": 0.0, "light_samples": None, "ref_light_samples": None,
        "size": "160x160",
        "radsplat": [
            ("a0.5-P16", ["-a", "0.5", "--plane-resolution", "16"]),
            ("a0.3-P16", ["-a", "0.3", "--plane-resolution", "16"]),
            ("a0.2-P24", ["-a", "0.2", "--plane-resolution", "24"]),
            ("a0.15-P24", ["-a", "0.15", "--plane-resolution", "24"]),
            ("a0.15-P32", ["-a", "0.15", "--plane-resolution", "32"]),
            ("a0.1-P32", ["-a", "0.1", "--plane-resolution", "32"]),
        ],
        "rpict": RPICT_POINTS,
    },
}
# Any other scene: the Cornell box's lists at the scene's own size.
FALLBACK = dict(SETTINGS["cornell-box"], spp=1024, size=None, ref_light_samples=None)


# What the reference estimates with, when it changes the references' noise: part of the
# cache key of the scenes it concerns, so that a cached reference from an older estimator
# is rendered again. Stop 51 draws rect lights by solid angle (the area-sampled ones
# carried fireflies beside panels: the conference room's reference noise 0.70 -> 0.195 %);
# scenes without a rect light keep their references.
REFERENCE_ESTIMATOR = "rect-lights-by-solid-angle"


def sha256_file(path, chunk=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                return h.hexdigest()
            h.update(b)


def key_of(*parts):
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:16]


def slug(label):
    return re.sub(r"[^A-Za-z0-9._-]+", "_", label)


def compare_indirect(radsplat, img, ref, out, env, downsample, minus=None):
    """`radsplat compare IMG REF --downsample N [--minus C] --json`; returns the JSON."""
    stem = Path(img).stem + ("-minus-" + Path(minus).stem if minus else "")
    js = out / "compare" / (stem + "-vs-ref.json")
    js.parent.mkdir(exist_ok=True)
    run([radsplat, "compare", img, ref, "--json", js, "--diff",
         out / "compare" / (stem + "-diff.png"), "--downsample", str(downsample)]
        + (["--minus", minus] if minus else []), env, quiet=True)
    return json.loads(js.read_text())


def timed(cmd, env, repeat, stdout_path=None, before=None):
    """Runs cmd `repeat` times; returns median wall and CPU seconds."""
    walls, cpus = [], []
    for _ in range(repeat):
        if before:
            before()
        if stdout_path is None:
            t, _ = run(cmd, env)
        else:
            with open(stdout_path, "wb") as f:
                t, _ = run(cmd, env, stdout=f)
        walls.append(t)
        cpus.append(LAST_CPU[0])
    return statistics.median(walls), statistics.median(cpus)


def pareto(points):
    """Points on the error/wall-time front, fastest first (each more accurate than every
    faster point)."""
    front, best = [], math.inf
    for p in sorted(points, key=lambda p: (p["wall_s"], p["error"])):
        if p["error"] < best:
            front.append(p)
            best = p["error"]
    return front


def time_at_error(front, e, key):
    """log(time) of a front (fastest first, errors decreasing) interpolated linearly in
    error at error e; None outside the front's error range."""
    for a, b in zip(front, front[1:]):
        lo, hi = b["error"], a["error"]
        if lo <= e <= hi:
            f = 0.0 if hi == lo else (hi - e) / (hi - lo)
            return math.exp(math.log(a[key]) + f * (math.log(b[key]) - math.log(a[key])))
    if len(front) == 1 and e == front[0]["error"]:
        return front[0][key]
    return None


def plot(path, scene, size, rad_pts, rp_pts, rad_front, rp_front, noise, downsample, ab=1):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5), dpi=110)
    for pts, front, colour, name in [(rad_pts, rad_front, "tab:blue", "radsplat"),
                                     (rp_pts, rp_front, "tab:orange", f"rpict -ab {ab}")]:
        ax.scatter([p["wall_s"] for p in pts], [100 * p["error"] for p in pts], color=colour,
                   alpha=0.35, s=22)
        ax.plot([p["wall_s"] for p in front], [100 * p["error"] for p in front], "o-",
                color=colour, label=f"{name} front")
        for p in pts:
            ax.annotate(p["label"], (p["wall_s"], 100 * p["error"]), fontsize=7,
                        xytext=(4, 3), textcoords="offset points", color=colour)
        d = next(p for p in pts if p["label"] == "defaults")
        ax.scatter([d["wall_s"]], [100 * d["error"]], marker="*", s=220, color=colour,
                   edgecolor="black", zorder=5, label=f"{name} defaults")
    ax.axhline(100 * noise, color="grey", ls=":", lw=1,
               label=f"reference noise {100 * noise:.2f} %")
    ax.set_xscale("log")
    ax.set_xlabel("wall time, s (log)")
    ax.set_ylabel(f"indirect relative RMSE, % ({downsample}x{downsample} box filter)")
    ax.set_title(f"{scene} {size}: error against time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--size", default=None,
                    help="WxH for every renderer (default: the table's size for the scene, "
                         "else the scene file's resolution)")
    ap.add_argument("--spp", type=int, default=None, help="reference bounce samples per pixel")
    ap.add_argument("--seeds", default="1,2",
                    help="the two reference seeds (`radsplat reference --seed`), A,B: A is the "
                         "yardstick, B measures its noise")
    ap.add_argument("--reference", type=Path, default=None,
                    help="reuse this reference EXR (radsplat reference on OUT/rad/notex.toml "
                         "at the same size) as reference A")
    ap.add_argument("--reference2", type=Path, default=None,
                    help="reuse this EXR as reference B (another seed than A's)")
    ap.add_argument("--reference2-spp", type=int, default=None,
                    help="B's samples per pixel when they differ from A's (--spp): A's noise "
                         "is then RMSE(A, B) / sqrt(1 + spp_A / spp_B), since B's variance "
                         "is spp_A / spp_B times A's")
    ap.add_argument("--downsample", type=int, default=4,
                    help="compare after an N x N box filter (default 4)")
    ap.add_argument("--dj", type=float, default=None, help="rpict -dj (default: the table's)")
    ap.add_argument("--ds", type=float, default=0.05, help="rpict -ds")
    ap.add_argument("--light-samples", type=int, default=None,
                    help="radsplat --light-samples for every radsplat run (default: the table's, "
                         "else the scene's)")
    ap.add_argument("--ref-light-samples", type=int, default=None,
                    help="the references' --light-samples (default: the table's, else the "
                         "scene's)")
    ap.add_argument("--settings", type=Path, default=None,
                    help="JSON file with this scene's entry in SETTINGS' shape (keys override "
                         "the built-in table): {\"radsplat\": [[label, [flags...]], ...], ...}")
    ap.add_argument("--only", choices=["radsplat", "rpict"], default=None,
                    help="rerender this side's points; take the other side's from the cache")
    ap.add_argument("--bounces", type=int, default=1,
                    help="bounces N on every side: radsplat --bounces N, rpict -ab N, the "
                         "references --bounces N (outputs in OUT-abN, plot peers-SCENE-abN.png)")
    ap.add_argument("--fresh", action="store_true", help="rerender every cached point")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs per point, median wall and CPU time (default 1)")
    ap.add_argument("--pair-alternate", type=int, default=0,
                    help="also time the defaults pair in N alternating runs of each side "
                         "(median of per-pair ratios); 0: off")
    ap.add_argument("--allow-noisy", action="store_true",
                    help="exit 0 even when the reference noise is not under a fifth of the "
                         "smallest error compared")
    ap.add_argument("--plot", type=Path, default=None,
                    help="PNG of the fronts (default docs/images/peers-<scene>.png)")
    ap.add_argument("--radsplat", type=Path, default=REPO / "target/release/radsplat")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()

    stem = args.scene.stem
    cfg = dict(SETTINGS.get(stem, FALLBACK))
    if args.settings:
        cfg.update(json.loads(args.settings.read_text()))
    spp = args.spp or cfg["spp"]
    dj = cfg["dj"] if args.dj is None else args.dj
    light_samples = args.light_samples or cfg.get("light_samples")
    ref_ls = args.ref_light_samples or cfg.get("ref_light_samples")
    size = args.size or cfg.get("size")
    seed_a, seed_b = (int(s) for s in args.seeds.split(","))

    env, radsplat, bindir = peer_env(args.radsplat)
    import pyradiance
    rad_version = getattr(pyradiance, "__version__", "?")
    if size is None:
        text = args.scene.read_text()
        m = re.search(r"resolution\s*=\s*\[\s*(\d+)\s*,\s*(\d+)\s*\]", text)
        if not m:
            sys.exit("no --size and no resolution found in the scene file")
        size = f"{m.group(1)}x{m.group(2)}"
    w, h = (int(v) for v in size.lower().split("x"))
    ab = args.bounces
    suffix = f"-ab{ab}" if ab > 1 else ""
    out = (args.out or REPO / "out/fronts" / f"{stem}-{w}x{h}{suffix}").resolve()
    (out / "points").mkdir(parents=True, exist_ok=True)
    plot_path = (args.plot or REPO / "docs/images" / f"peers-{stem}{suffix}.png").resolve()

    print(f"== {args.scene} at {w}x{h}, output in {out}", file=sys.stderr)
    run([radsplat, "export-rad", args.scene, out / "rad", "--size", size], env)
    info = json.loads((out / "rad/export.json").read_text())
    notex = out / "rad/notex.toml"
    view = info["view"].split()
    oct_path = out / "scene.oct"
    scene_rad_hash = sha256_file(out / "rad/scene.rad")
    oct_key = out / "scene.oct.key"
    if not oct_path.exists() or not oct_key.exists() or oct_key.read_text() != scene_rad_hash:
        with open(oct_path, "wb") as f:
            run([bindir / "oconv", out / "rad/scene.rad"], env, stdout=f)
        oct_key.write_text(scene_rad_hash)
    notex_hash = sha256_file(notex)
    # Only references of scenes with a rect light changed with `REFERENCE_ESTIMATOR`.
    has_rect_light = any(light.get("type") == "rect"
                         for light in tomllib.loads(notex.read_text()).get("light", []))
    radsplat_hash = sha256_file(radsplat)
    ls = ["--light-samples", str(light_samples)] if light_samples else []
    common = ["--size", size, "--quiet"] + ls + (["--bounces", str(ab)] if ab > 1 else [])

    def cached(side, label, key, render):
        """Cached point or a new render (render() returns the point's dict)."""
        path = out / "points" / f"{side}-{slug(label)}.json"
        rerender = args.fresh or args.only == side
        if path.exists() and not rerender:
            p = json.loads(path.read_text())
            if p.get("key") == key and Path(p["image"]).exists():
                print(f"  cached: {side} {label}", file=sys.stderr)
                return p
        if args.only is not None and args.only != side:
            sys.exit(f"--only {args.only}: no cached {side} point '{label}' matching this "
                     f"scene/settings in {out / 'points'}; run without --only first")
        p = render()
        p.update(side=side, label=label, key=key)
        path.write_text(json.dumps(p, indent=2))
        return p

    # References A and B (seeds differ): A is the yardstick, A vs B measures its noise.
    refs = []
    for given, seed in [(args.reference, seed_a), (args.reference2, seed_b)]:
        if given is not None:
            refs.append({"image": str(given.resolve()), "seed": None, "given": True})
            continue
        key = key_of("reference", notex_hash, size, spp, seed, ref_ls, *([ab] if ab > 1 else []),
                     *([REFERENCE_ESTIMATOR] if has_rect_light else []))
        img = out / f"reference-seed{seed}.exr"
        meta = out / f"reference-seed{seed}.json"
        if meta.exists() and img.exists() and json.loads(meta.read_text()).get("key") == key \
                and not args.fresh:
            print(f"  cached: reference seed {seed}", file=sys.stderr)
            refs.append(json.loads(meta.read_text()))
            continue
        t, _ = run([radsplat, "reference", notex, "--spp", str(spp), "--seed", str(seed),
                    "-o", img, "--size", size, "--quiet", "--bounces", str(ab)]
                   + (["--light-samples", str(ref_ls)] if ref_ls else []), env)
        r = {"image": str(img), "seed": seed, "spp": spp, "light_samples": ref_ls,
             "wall_s": t, "cpu_s": LAST_CPU[0], "key": key}
        meta.write_text(json.dumps(r, indent=2))
        refs.append(r)
    ref_a, ref_b = Path(refs[0]["image"]), Path(refs[1]["image"])
    c = compare_indirect(radsplat, ref_b, ref_a, out, env, args.downsample)
    ref_pair = c["indirect"]["relative_rmse"]
    # Variances add: RMSE(A, B)^2 = n_A^2 (1 + spp_A / spp_B).
    noise = ref_pair / math.sqrt(1.0 + spp / (args.reference2_spp or spp))
    print(f"reference noise: A vs B indirect relative RMSE {100 * ref_pair:.3f} % -> one "
          f"reference {100 * noise:.3f} % ({spp} spp, seeds {args.seeds}, "
          f"{args.downsample}x{args.downsample} box filter)", file=sys.stderr)

    # radsplat points. lavapipe compiles a shader on its first dispatch and keeps it in
    # Mesa's disk cache: one untimed render at 64x64 first, so that the first timed point
    # (the defaults) does not pay the compilation of a new build (rpict has nothing alike).
    rad_settings = [("defaults", [])] + [tuple(s) for s in cfg["radsplat"]]
    warm = out / "radsplat-warm-up.exr"
    run([radsplat, "render", notex, "-o", warm, "--size", "64x64", "--quiet"], env)
    rad_pts = []

    def rad_cmd(label, flags):
        img = out / f"radsplat-{slug(label)}.exr"
        stats = out / f"radsplat-{slug(label)}-stats.json"
        return [radsplat, "render", notex, "-o", img, "--stats", stats] + flags + common, img, stats

    for label, flags in rad_settings:
        def render(label=label, flags=flags):
            cmd, img, stats = rad_cmd(label, flags)
            wall, cpu = timed(cmd, env, args.repeat)
            records = json.loads(stats.read_text())["frame"]["cache"]["records"]
            return {"command": " ".join(map(str, cmd)), "flags": flags, "wall_s": wall,
                    "cpu_s": cpu, "records": records, "image": str(img)}
        key = key_of("radsplat", radsplat_hash, notex_hash, size, flags, light_samples,
                     args.repeat)
        rad_pts.append(cached("radsplat", label, key, render))

    # rpict: pixel centres, every pixel traced (-pj 0 -ps 1 -pt 0 -pa 0), the direct
    # settings of compare_peers.py; -ab 0 once (shared), -ab N per setting. -lr N: each
    # ambient bounce is one level of ray depth, so -lr 1 would cut -ab 2 down to -ab 1.
    rp = [bindir / "rpict"] + view + ["-x", w, "-y", h, "-pa", "0", "-pj", "0", "-ps", "1",
                                      "-pt", "0", "-dt", "0", "-dc", "1", "-dj", str(dj),
                                      "-ds", args.ds, "-dr", "0", "-lr", str(ab)]
    rp = [str(x) for x in rp]
    rp_key_base = (rad_version, scene_rad_hash, info["view"], size, dj, args.ds)

    def render_ab0():
        img = out / "rpict-ab0.hdr"
        cmd = rp + ["-ab", "0", str(oct_path)]
        wall, cpu = timed(cmd, env, 1, stdout_path=img)
        return {"command": " ".join(cmd), "wall_s": wall, "cpu_s": cpu, "image": str(img)}
    ab0 = cached("rpict", "ab0", key_of("rpict-ab0", *rp_key_base), render_ab0)
    rp_settings = [("defaults", [])] + [tuple(s) for s in cfg["rpict"]]
    rp_pts = []

    def rp_cmd(label, flags):
        img = out / f"rpict-{slug(label)}.hdr"
        amb = out / f"rpict-{slug(label)}.amb"
        return rp + ["-ab", str(ab)] + flags + ["-af", str(amb), str(oct_path)], img, amb

    for label, flags in rp_settings:
        def render(label=label, flags=flags):
            cmd, img, amb = rp_cmd(label, flags)
            wall, cpu = timed(cmd, env, args.repeat, stdout_path=img,
                              before=lambda: amb.unlink() if amb.exists() else None)
            return {"command": " ".join(cmd), "flags": flags, "wall_s": wall, "cpu_s": cpu,
                    "records": count_ambient_records(bindir, amb, env), "image": str(img)}
        key = key_of("rpict", *rp_key_base, flags, args.repeat, *([ab] if ab > 1 else []))
        rp_pts.append(cached("rpict", label, key, render))

    # Errors (always recomputed: they depend on the reference).
    for p in rad_pts:
        c = compare_indirect(radsplat, p["image"], ref_a, out, env, args.downsample)
        p["error"] = c["indirect"]["relative_rmse"]
        p["beauty_rel_rmse"] = c["beauty"]["relative_rmse"]
    for p in rp_pts:
        c = compare_indirect(radsplat, p["image"], ref_a, out, env, args.downsample,
                             minus=ab0["image"])
        p["error"] = c["indirect"]["relative_rmse"]
        p["beauty_rel_rmse"] = compare_indirect(radsplat, p["image"], ref_a, out, env,
                                                args.downsample)["beauty"]["relative_rmse"]
    for p in rad_pts + rp_pts:
        # The reference's noise adds in quadrature: the error against the true image.
        p["error_noise_corrected"] = math.sqrt(max(p["error"] ** 2 - noise ** 2, 0.0))

    rad_front, rp_front = pareto(rad_pts), pareto(rp_pts)
    lines = []

    def say(s=""):
        lines.append(s)
        print(s)

    say(f"{args.scene} at {w}x{h}; error = indirect relative RMSE after a "
        f"{args.downsample}x{args.downsample} box filter, against reference A "
        f"({spp} spp, seed {refs[0]['seed']})")
    say(f"reference noise (A vs B / sqrt(1 + spp_A / spp_B)): {100 * noise:.3f} %  "
        f"(A vs B: {100 * ref_pair:.3f} %)")
    for name, pts, front in [("radsplat", rad_pts, rad_front), ("rpict", rp_pts, rp_front)]:
        say()
        say(f"{name:<9} {'setting':<14} {'flags':<40} {'wall s':>8} {'cpu s':>8} "
            f"{'records':>8} {'error %':>8} {'front':>5}")
        for p in sorted(pts, key=lambda p: p["wall_s"]):
            flags = " ".join(p["flags"]) or ("(none)" if name == "radsplat" else f"(-ab {ab} only)")
            say(f"{name:<9} {p['label']:<14} {flags:<40} {p['wall_s']:>8.2f} {p['cpu_s']:>8.2f} "
                f"{p['records']:>8} {100 * p['error']:>8.3f} {'*' if p in front else '':>5}")
    say()
    say("speed ratio at matched error (rpict's front, log time interpolated in error) / radsplat:")
    lo_e = min(p["error"] for p in rp_front)
    hi_e = max(p["error"] for p in rp_front)
    ratios = []
    for p in sorted(rad_pts, key=lambda p: p["wall_s"]):
        tw = time_at_error(rp_front, p["error"], "wall_s")
        tc = time_at_error(rp_front, p["error"], "cpu_s")
        if tw is None:
            where = "below" if p["error"] < lo_e else "above"
            say(f"  radsplat {p['label']:<14} error {100 * p['error']:.3f} %: {where} rpict's "
                f"front range {100 * lo_e:.3f}-{100 * hi_e:.3f} %, no ratio")
            ratios.append({"label": p["label"], "error": p["error"], "wall_ratio": None,
                           "cpu_ratio": None, "outside": where})
            continue
        ratios.append({"label": p["label"], "error": p["error"], "rpict_wall_s": tw,
                       "rpict_cpu_s": tc, "wall_ratio": tw / p["wall_s"],
                       "cpu_ratio": tc / p["cpu_s"], "on_front": p in rad_front})
        say(f"  radsplat {p['label']:<14} error {100 * p['error']:.3f} %: rpict needs "
            f"{tw:.2f} s wall / {tc:.2f} s CPU -> {tw / p['wall_s']:.2f}x wall, "
            f"{tc / p['cpu_s']:.2f}x CPU{'' if p in rad_front else '  (not on front)'}")
    rd = next(p for p in rad_pts if p["label"] == "defaults")
    pd = next(p for p in rp_pts if p["label"] == "defaults")
    faster = rd["wall_s"] < pd["wall_s"]
    accurate = rd["error"] <= pd["error"]
    verdict = "PASS" if faster and accurate else "FAIL"
    say()
    say(f"defaults pair: radsplat defaults {rd['wall_s']:.2f} s wall / {rd['cpu_s']:.2f} s CPU, "
        f"error {100 * rd['error']:.3f} %; rpict defaults -ab {ab} {pd['wall_s']:.2f} s / "
        f"{pd['cpu_s']:.2f} s, error {100 * pd['error']:.3f} %: "
        f"{pd['wall_s'] / rd['wall_s']:.2f}x faster (wall), {pd['cpu_s'] / rd['cpu_s']:.2f}x "
        f"(CPU), error ratio {rd['error'] / pd['error']:.3f}: "
        f"{'faster' if faster else 'SLOWER'}, {'no less accurate' if accurate else 'LESS ACCURATE'}"
        f" -> {verdict}")
    alternating = None
    if args.pair_alternate > 0:
        # The two defaults in turn (who goes first alternates): each pair's runs are seconds
        # apart, so the machine's drift over the minutes between the two sides' points above
        # does not enter the ratio. The images are the points' own (the same bytes).
        rcmd, _, _ = rad_cmd("defaults", [])
        pcmd, pimg, pamb = rp_cmd("defaults", [])
        rad_t, rp_t = [], []
        for i in range(args.pair_alternate):
            for side in (("rad", "rp") if i % 2 == 0 else ("rp", "rad")):
                if side == "rad":
                    wall, cpu = timed(rcmd, env, 1)
                    rad_t.append((wall, cpu))
                else:
                    wall, cpu = timed(pcmd, env, 1, stdout_path=pimg,
                                      before=lambda: pamb.unlink() if pamb.exists() else None)
                    rp_t.append((wall, cpu))
        wall_ratios = [p[0] / r[0] for r, p in zip(rad_t, rp_t)]
        cpu_ratios = [p[1] / r[1] for r, p in zip(rad_t, rp_t)]
        alternating = {
            "pairs": args.pair_alternate,
            "radsplat_wall_s": [r[0] for r in rad_t], "rpict_wall_s": [p[0] for p in rp_t],
            "wall_ratio": statistics.median(wall_ratios),
            "cpu_ratio": statistics.median(cpu_ratios),
            "verdict": "PASS" if statistics.median(wall_ratios) > 1 and accurate else "FAIL",
        }
        say(f"defaults pair, {args.pair_alternate} alternating pairs: rpict / radsplat wall "
            f"{alternating['wall_ratio']:.2f}x (per pair "
            f"{' '.join(f'{x:.2f}' for x in wall_ratios)}), CPU {alternating['cpu_ratio']:.2f}x;"
            f" radsplat median {statistics.median(alternating['radsplat_wall_s']):.2f} s, "
            f"rpict {statistics.median(alternating['rpict_wall_s']):.2f} s -> "
            f"{alternating['verdict']}")
    smallest = min(p["error"] for p in rad_pts + rp_pts)
    noisy = not noise < smallest / 5
    if noisy:
        say()
        say(f"!!! WARNING: the reference noise {100 * noise:.3f} % is not under a fifth of the "
            f"smallest error compared ({100 * smallest:.3f} % / 5 = {100 * smallest / 5:.3f} %): "
            f"raise --spp (noise ~ 1/sqrt(spp)) or --downsample. !!!")

    # Conversion check: rpict -ab 0 against radsplat's direct light (validates units).
    # 32 light samples per area light (the scene's 4 leave ~30 % relative RMSE of noise on
    # the conference room, whose walls touch its six panels): 6 x 32 = 192 shadow rays, under
    # lavapipe's 256 per pixel.
    direct = out / "radsplat-direct-ls32.exr"
    if not direct.exists() or args.fresh or args.only == "radsplat":
        run([radsplat, "render", notex, "--direct-only", "-o", direct, "--size", size,
             "--quiet", "--light-samples", "32"], env)
    vc = compare_indirect(radsplat, ab0["image"], direct, out, env, 1)
    conv = (vc.get("surfaces") or vc["beauty"])["relative_rmse"]
    say(f"conversion check, rpict -ab 0 vs radsplat direct only (surfaces): relative RMSE "
        f"{100 * conv:.2f} %")

    plot(plot_path, stem, f"{w}x{h}", rad_pts, rp_pts, rad_front, rp_front, noise,
         args.downsample, ab)
    say(f"plot: {plot_path}")
    summary = {
        "scene": str(args.scene), "width": w, "height": h, "downsample": args.downsample,
        "reference": {"a": refs[0], "b": refs[1], "spp": spp, "light_samples": ref_ls,
                      "pair_relative_rmse": ref_pair, "noise": noise, "noisy": noisy,
                      "smallest_error": smallest},
        "rpict": {"pyradiance": rad_version, "dj": dj, "ds": args.ds, "ab0": ab0},
        "light_samples": light_samples, "radsplat_sha256": radsplat_hash,
        "radsplat_points": rad_pts, "rpict_points": rp_pts,
        "radsplat_front": [p["label"] for p in rad_front],
        "rpict_front": [p["label"] for p in rp_front],
        "ratios": ratios,
        "defaults_pair": {"radsplat": rd, "rpict": pd, "faster": faster,
                          "no_less_accurate": accurate, "verdict": verdict,
                          "alternating": alternating},
        "conversion_check_relative_rmse": conv, "plot": str(plot_path),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    (out / "fronts.txt").write_text("\n".join(lines) + "\n")
    print(f"wrote {out / 'summary.json'} and {out / 'fronts.txt'}")
    if noisy and not args.allow_noisy:
        sys.exit(3)


if __name__ == "__main__":
    main()
