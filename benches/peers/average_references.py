#!/usr/bin/env python3
"""Averages radsplat references of different seeds into one reference of their summed
samples per pixel (issue 17's harness: a reference whose own noise is under a fifth of the
smallest error compared).

    average_references.py OUT.exr A1.exr A2.exr ... [--json OUT.json]

Each input is `radsplat reference SCENE --spp N --seed S` at the same size, spp and light
samples, with different seeds: their estimates are independent, so the mean of K of them
is an estimate with K N samples per pixel (variance / K), and `fronts.py --reference OUT.exr
--spp K*N --reference2 B.exr --reference2-spp N` then reads its noise from a further seed
B. Every channel is averaged (float32, in input order, so the output is the same bytes
for the same inputs); the header is the first input's. The output is written to a
temporary file beside OUT and renamed, as radsplat writes its own images.
"""

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
import OpenEXR
import Imath

FLOAT = Imath.PixelType(Imath.PixelType.FLOAT)


def read(path):
    f = OpenEXR.InputFile(str(path))
    h = f.header()
    dw = h["dataWindow"]
    w, ht = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    chans = sorted(h["channels"].keys())
    data = {c: np.frombuffer(f.channel(c, FLOAT), dtype=np.float32).reshape(ht, w)
            for c in chans}
    return h, (w, ht), data


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("inputs", type=Path, nargs="+")
    ap.add_argument("--json", type=Path, default=None,
                    help="write the inputs and their count here")
    args = ap.parse_args()
    if len(args.inputs) < 2:
        sys.exit("average_references.py: give at least two references")
    head, size, acc = read(args.inputs[0])
    acc = {c: v.astype(np.float64) for c, v in acc.items()}
    for p in args.inputs[1:]:
        _, s, d = read(p)
        if s != size or sorted(d) != sorted(acc):
            sys.exit(f"average_references.py: {p}: size {s} or channels differ from "
                     f"{args.inputs[0]}'s ({size})")
        for c in acc:
            acc[c] += d[c]
    k = float(len(args.inputs))
    head = dict(head)
    head["channels"] = {c: Imath.Channel(FLOAT) for c in acc}
    tmp = args.out.with_name(args.out.name + ".tmp.exr")
    out = OpenEXR.OutputFile(str(tmp), head)
    out.writePixels({c: (v / k).astype(np.float32).tobytes() for c, v in acc.items()})
    out.close()
    os.replace(tmp, args.out)
    if args.json:
        args.json.write_text(json.dumps(
            {"image": str(args.out), "inputs": [str(p) for p in args.inputs],
             "count": len(args.inputs)}, indent=2))
    print(f"{args.out}: mean of {len(args.inputs)} references, {size[0]}x{size[1]}, "
          f"{len(acc)} channels")


if __name__ == "__main__":
    main()
