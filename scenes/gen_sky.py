#!/usr/bin/env python3
"""Writes sky.hdr, radsplat's own small environment map (64 x 32, latitude-longitude,
Radiance RGBE with flat scanlines): a blue sky brightening to the horizon, a sun of about
3 degrees at 35 degrees elevation, a dim brown ground. Map frame (docs/scene-format.md):
row 0 is the zenith, column 0 looks along -z, columns run towards +x. Run from scenes/."""
import math

W, H = 64, 32
SUN_PHI, SUN_ELEVATION = 1.1, math.radians(35.0)
SUN = (2000.0, 1800.0, 1500.0)


def rgbe(r, g, b):
    v = max(r, g, b)
    if v < 1e-32:
        return bytes((0, 0, 0, 0))
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes((int(r * scale), int(g * scale), int(b * scale), e + 128))


def radiance(theta, phi):
    if theta > math.pi / 2:
        return (0.08, 0.06, 0.04)  # ground
    up = math.cos(theta)
    sky = (0.25 + 0.55 * (1 - up), 0.45 + 0.45 * (1 - up), 1.0)
    # The sun: the texels whose centre is within 3 degrees of its direction.
    s = (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))
    se = math.pi / 2 - SUN_ELEVATION
    d = (math.sin(se) * math.sin(SUN_PHI), math.cos(se), -math.sin(se) * math.cos(SUN_PHI))
    if sum(a * b for a, b in zip(s, d)) > math.cos(math.radians(3.0)):
        return SUN
    return sky


with open("sky.hdr", "wb") as f:
    f.write(b"#?RADIANCE\n# radsplat's own sky (gen_sky.py)\nFORMAT=32-bit_rle_rgbe\n\n")
    f.write(f"-Y {H} +X {W}\n".encode())
    for j in range(H):
        theta = math.pi * (j + 0.5) / H
        for i in range(W):
            phi = 2 * math.pi * (i + 0.5) / W
            f.write(rgbe(*radiance(theta, phi)))
