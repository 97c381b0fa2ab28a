#!/usr/bin/env python3
"""Where a small still's time goes: the part that does not shrink with the image.

On a small image (the peer harness's 160x160 defaults pairs) radsplat's wall time is not
mostly its rays: a process pays its start-up (Vulkan instance, pipelines), and a frame
pays costs that do not follow the plane rays (first-dispatch compilation on drivers that
compile then, the light maps, a fixed number of placement rounds and their dispatches).
This measures both, for one scene, with the binary as users run it (no `--time-passes`):

1. **Sizes.** The scene at its own size and smaller ones (the same aspect), RUNS times
   each, interleaved. Per size: the median process wall, start-up (the phases before the
   frame, `--stats` `command_ms`), frame, plane rays and placement rounds. Then a least-
   squares line frame = fixed + per_ray * plane_rays through the per-size medians: `fixed`
   is the frame's part that no ray count explains. The process's other part is its
   start-up and its end (encoding, writing, tearing down): process - frame.

(A serial part estimated from one thread against several, S + P = F1 and S + P / s = Fn,
was tried and left out: a difference of two noisy frames, it read 12 % and 65 % of the
same frame in two runs on this machine.)

    benches/startup/fixed_cost.py [SCENE] [--runs 5] [--sizes 1,0.8,0.6,0.4,0.2]
        [--bin target/release/radsplat] [-- extra render flags]

Standard library only; needs RADSPLAT_ASSET_PATH for scenes outside the repository.
docs/results.md ("Where a small still's time goes", stop 69) has a run on nave-west.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "benches", "variants"))
from sizes import own_size  # noqa: E402  (the scene's [camera] resolution)


def render(binary, scene, size, flags):
    """One render; its --stats JSON and wall seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        stats = os.path.join(tmp, "s.json")
        cmd = [binary, "render", scene, "--size", size, "-o", os.path.join(tmp, "o.exr"),
               "--stats", stats, "--quiet"] + flags
        t0 = time.monotonic()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.monotonic() - t0
        if r.returncode != 0:
            sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
        with open(stats) as f:
            return json.load(f), wall


def phases(stats):
    ms = dict(stats["command_ms"])
    frame = ms.get("frame", 0.0)
    before = 0.0
    for name, v in stats["command_ms"]:
        if name == "frame":
            break
        before += v
    return before, frame


def fit(xs, ys):
    """Least-squares line y = a + b x."""
    mx, my = statistics.mean(xs), statistics.mean(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 0.0
    return my - b * mx, b


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "benches/variants/nave-west.toml"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", default="1,0.8,0.6,0.4,0.2",
                    help="fractions of the scene's own width and height")
    ap.add_argument("--bin", default=os.path.join(ROOT, "target/release/radsplat"))
    ap.add_argument("flags", nargs="*", help="extra render flags (after --)")
    a = ap.parse_args()
    w, h = own_size(a.scene)
    sizes = []
    for f in (float(s) for s in a.sizes.split(",")):
        sw, sh = max(4, round(w * f / 4) * 4), max(4, round(h * f / 4) * 4)
        sizes.append(f"{sw}x{sh}")
    render(a.bin, a.scene, sizes[-1], a.flags)  # warms Mesa's shader cache
    rows = {s: [] for s in sizes}
    for _ in range(a.runs):
        for s in sizes:
            stats, wall = render(a.bin, a.scene, s, a.flags)
            start, frame = phases(stats)
            cache = stats["frame"].get("cache") or {}
            rows[s].append((wall * 1e3, start, frame, cache.get("plane_rays", 0),
                            cache.get("rounds", 0), stats["frame"].get("gpu_waits", 0)))
    print(f"{a.scene}, {a.runs} runs a size (medians, ms)")
    print(f"{'size':>9} {'process':>8} {'start-up':>9} {'frame':>7} {'plane rays':>11} "
          f"{'rounds':>7} {'waits':>6}")
    xs, ys = [], []
    for s in sizes:
        med = [statistics.median(r[i] for r in rows[s]) for i in range(6)]
        print(f"{s:>9} {med[0]:8.0f} {med[1]:9.0f} {med[2]:7.0f} {med[3]:11.0f} "
              f"{med[4]:7.0f} {med[5]:6.0f}")
        xs.append(med[3])
        ys.append(med[2])
    fixed, per_ray = fit(xs, ys)
    own = ys[0]
    if per_ray <= 0 or fixed < 0:
        print("the frames do not grow with the plane rays here (a busy machine, or sizes "
              "too close): no split; run again, or with more sizes or runs")
        return
    print(f"frame = {fixed:.0f} ms + {per_ray * 1e3:.3f} us x plane rays "
          f"(least squares over the sizes): at the own size {fixed / own:.0%} of the frame "
          f"does not follow the rays")
    process = statistics.median(r[0] for r in rows[sizes[0]])
    rest = process - own
    print(f"at {sizes[0]}: of the process's {process:.0f} ms, {rest + fixed:.0f} ms "
          f"({(rest + fixed) / process:.0%}) do not follow the rays: the frame's {fixed:.0f} "
          f"and {rest:.0f} outside it (start-up, encoding, the end)")


if __name__ == "__main__":
    main()
