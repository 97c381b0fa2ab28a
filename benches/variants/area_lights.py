#!/usr/bin/env python3
"""Scenes lit by area lights: the indirect error and wall time of flag sets.

The defaults pairs leave radsplat its thinnest accuracy margin on the conference room
(docs/results.md, stop 69), where area lights light the plane hits with one shadow sample
each. This renders the bundled area-light scenes (and the conference room and its variant
where RADSPLAT_ASSET_PATH finds the model) at two sizes each, with each flag set, and
prints each set's indirect relative RMSE (4x4 box filter, against a reference rendered
once per scene and size and kept in the output folder) and the median wall time of three
renders.

    benches/variants/area_lights.py [--bin target/release/radsplat] [--out DIR]
        [--only cornell,conference] LABEL=FLAGS ...

e.g. `base= "pls2=--plane-light-samples 2" "a20=-a 0.2"`. Standard library only.
"""
import argparse
import os
import statistics
import sys

from check import ROOT, compare, found, reference, render

SCENES = [
    ("cornell", "scenes/cornell-box.toml", "128x128", None),
    ("cornell96", "scenes/cornell-box.toml", "96x96", None),
    ("conference", "scenes/conference.toml", "160x120", "conference/conference_geometry_only.obj"),
    ("conference128", "scenes/conference.toml", "128x96", "conference/conference_geometry_only.obj"),
    ("conf-west", "benches/variants/conference-west.toml", "160x120", "conference/conference_geometry_only.obj"),
    ("conf-west144", "benches/variants/conference-west.toml", "144x108", "conference/conference_geometry_only.obj"),
    ("cornell-sphere", "scenes/cornell-sphere.toml", "128x128", None),
    ("cube", "scenes/cube-in-box.toml", "128x128", None),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "radsplat"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "area-lights"))
    ap.add_argument("--only", default=None, help="comma-separated scene labels")
    ap.add_argument("sets", nargs="*", help="LABEL=FLAGS (flags separated by spaces)")
    a = ap.parse_args()
    sets = [(s.split("=", 1)[0], s.split("=", 1)[1].split()) for s in a.sets] or [("base", [])]
    os.makedirs(a.out, exist_ok=True)
    for name, scene, size, asset in SCENES:
        if a.only and name not in a.only.split(","):
            continue
        if asset and not found(asset):
            print(f"{name}: skipped ({asset} not found along RADSPLAT_ASSET_PATH)")
            continue
        scene = os.path.join(ROOT, scene)
        ref = os.path.join(a.out, f"{name}-ref.exr")
        reference(a.bin, scene, ref, 1024, 1, size)
        row = [name]
        for label, flags in sets:
            img = os.path.join(a.out, f"{name}-{label}.exr")
            times = [render(a.bin, scene, img, flags, size) for _ in range(3)]
            c = compare(a.bin, img, ref, os.path.join(a.out, f"{name}-{label}.json"))
            row.append(f"{label} {100 * c['indirect']['relative_rmse']:.3f}% "
                       f"{statistics.median(times):.2f}s")
        print(" | ".join(row), flush=True)


if __name__ == "__main__":
    sys.exit(main())
