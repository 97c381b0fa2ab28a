#!/usr/bin/env python3
"""Writes nave.obj / nave.mtl: a stone hall lit by a low sun through small windows (our own files).

A stand-in, written by us, for the kind of scene issue 17 measured outside the repo (a
cathedral interior lit by a low sun through small openings): nearly all of the light the
camera sees is indirect, and it comes from a few bright patches that the sun throws
through the windows onto the floor, the piers and the far wall. A record whose hemisphere
misses those patches sees nothing at all, which is what made radsplat's floors splotchy
and zero there. Used by nave.toml and the peer harness (benches/peers/fronts.py).

Every solid is a closed box with outward faces (two triangles a face, flat normals):
  - floor slab, roof slab, two end walls;
  - the south wall (z < 0) with a row of small windows, built from boxes around the holes;
  - the north wall, solid;
  - a row of square piers down each side of the nave, and a low screen wall between
    two of them, so that the floor sees the patches only round corners.

Deterministic (no randomness, fixed formatting): rerunning it reproduces the committed files.

Usage: python3 scenes/gen_nave.py   (from anywhere; writes next to this script)
       python3 scenes/gen_nave.py --bare --out DIR   (the hall without its piers and screen,
       DIR/nave-bare.obj and .mtl: a variant benches/variants renders)
"""

import argparse
import os

HERE = os.path.dirname(os.path.abspath(__file__))

# Interior: x 0..LENGTH (west to east), y 0..HEIGHT, z 0..WIDTH (south to north), metres.
LENGTH, WIDTH, HEIGHT = 24.0, 10.0, 11.0
WALL = 0.8  # wall thickness
WINDOW_XS = [3.0, 7.0, 11.0, 15.0, 19.0]  # window centres along the south wall
WINDOW_W, WINDOW_Y0, WINDOW_Y1 = 0.9, 4.5, 6.5
PIER = 0.9  # square piers, side
PIER_XS = [5.0, 9.0, 13.0, 17.0, 21.0]
PIER_ZS = [2.6, 7.4]


def box(lo, hi):
    """The six outward faces of an axis-aligned box: (normal, four corners counter-clockwise)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        ((-1, 0, 0), [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)]),
        ((1, 0, 0), [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)]),
        ((0, -1, 0), [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)]),
        ((0, 1, 0), [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)]),
        ((0, 0, -1), [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)]),
        ((0, 0, 1), [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]),
    ]


def solids(bare=False):
    """(material, lo, hi) for every box of the hall (`bare`: without piers and screen)."""
    w = WALL
    out = [
        ("floor", (-w, -w, -w), (LENGTH + w, 0.0, WIDTH + w)),
        ("stone", (-w, HEIGHT, -w), (LENGTH + w, HEIGHT + w, WIDTH + w)),
        ("stone", (-w, 0.0, -w), (0.0, HEIGHT, WIDTH + w)),  # west wall
        ("stone", (LENGTH, 0.0, -w), (LENGTH + w, HEIGHT, WIDTH + w)),  # east wall
        ("stone", (0.0, 0.0, WIDTH), (LENGTH, HEIGHT, WIDTH + w)),  # north wall
        # South wall: below and above the windows, then the piers between them.
        ("stone", (0.0, 0.0, -w), (LENGTH, WINDOW_Y0, 0.0)),
        ("stone", (0.0, WINDOW_Y1, -w), (LENGTH, HEIGHT, 0.0)),
    ]
    edges = [0.0]
    for xc in WINDOW_XS:
        edges += [xc - WINDOW_W / 2, xc + WINDOW_W / 2]
    edges.append(LENGTH)
    for x0, x1 in zip(edges[0::2], edges[1::2]):
        out.append(("stone", (x0, WINDOW_Y0, -w), (x1, WINDOW_Y1, 0.0)))
    if bare:
        return out
    h = PIER / 2
    for z in PIER_ZS:
        for x in PIER_XS:
            out.append(("stone", (x - h, 0.0, z - h), (x + h, HEIGHT, z + h)))
    # A screen wall between the first two north piers (the choir screen).
    out.append(("stone", (PIER_XS[1] + PIER / 2, 0.0, PIER_ZS[1] - 0.15),
                (PIER_XS[2] - PIER / 2, 2.2, PIER_ZS[1] + 0.15)))
    return out


def fmt(v):
    return " ".join(f"{c:.4f}".rstrip("0").rstrip(".") if c != 0 else "0" for c in v)


def main():
    ap = argparse.ArgumentParser(description="Writes the nave's OBJ and MTL.")
    ap.add_argument("--bare", action="store_true", help="no piers, no screen wall")
    ap.add_argument("--out", default=HERE, help="directory to write into")
    args = ap.parse_args()
    stem = "nave-bare" if args.bare else "nave"
    lines = [f"# {stem}.obj: written by gen_nave.py (do not edit)", f"mtllib {stem}.mtl"]
    normals = [(-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1)]
    lines += [f"vn {fmt(n)}" for n in normals]
    vcount = 0
    body = []
    current = None
    for material, lo, hi in solids(args.bare):
        if material != current:
            body.append(f"usemtl {material}")
            current = material
        for normal, quad in box(lo, hi):
            n = normals.index(normal) + 1
            body += [f"v {fmt(p)}" for p in quad]
            a, b, c, d = (vcount + i for i in range(1, 5))
            body.append(f"f {a}//{n} {b}//{n} {c}//{n}")
            body.append(f"f {a}//{n} {c}//{n} {d}//{n}")
            vcount += 4
    with open(os.path.join(args.out, f"{stem}.obj"), "w", newline="\n") as f:
        f.write("\n".join(lines + body) + "\n")
    with open(os.path.join(args.out, f"{stem}.mtl"), "w", newline="\n") as f:
        f.write(f"# {stem}.mtl: written by gen_nave.py (do not edit)\n")
        f.write("newmtl stone\nKd 0.62 0.58 0.52\n\n")
        f.write("newmtl floor\nKd 0.45 0.42 0.40\n")


if __name__ == "__main__":
    main()
