#!/usr/bin/env python3
"""Draws docs/images/spheres-glossy-front.png: glossy Spheres 96x72, frames 0..11, error and
frame-to-frame change error against wall time for temporal caching and per-frame
recomputation at several settings (the figures of docs/results.md, "Cosine-spaced planes
and one-frame records on moving instances", stop 44; measured on the 2-core development
machine with lavapipe, medians where two runs were made). Needs matplotlib
(benches/peers/.venv).

    python3 benches/temporal/plot_spheres_front.py docs/images/spheres-glossy-front.png
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

# (label, wall s, RMSE % against 256-spp references over frames 0..11,
#  noise-corrected change error % against 1,024-spp references over frames 0..5, temporal?)
POINTS = [
    ("temporal, stop 43 default (even 130° planes)", 52.5, 1.286, 1.092, True),
    ("temporal, --mover-records by-change", 52.9, 1.043, 0.971, True),
    ("temporal, default", 59.0, 0.960, 0.677, True),
    ("temporal, --temporal-refine", 70.2, 0.929, 0.627, True),
    ("temporal, Monte Carlo glossy", 29.0, 1.267, 1.235, True),
    ("per frame, default", 84.0, 0.867, 0.647, False),
    ("per frame, --plane-refine 0", 60.5, 0.893, 0.792, False),
    ("per frame, --plane-refine 0 --plane-resolution 16", 29.1, 1.096, 1.113, False),
    ("per frame, Monte Carlo glossy", 38.1, 1.197, 1.213, False),
]


def main(out):
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.4))
    for ax, k, ylabel in (
        (axes[0], 0, "relative RMSE, % (256-spp references)"),
        (axes[1], 1, "change error, % (1,024-spp references, noise removed)"),
    ):
        for n, (label, t, rmse, change, temporal) in enumerate(POINTS, start=1):
            v = (rmse, change)[k]
            default = label.endswith("default") and "stop 43" not in label
            ax.scatter(
                t, v,
                marker="o" if temporal else "s",
                s=110 if default else 45,
                color="tab:blue" if temporal else "tab:orange",
                edgecolor="black" if default else "none",
                zorder=3,
            )
            # Numbers, not labels, next to the points (the legend below names them).
            ax.annotate(str(n), (t, v), textcoords="offset points", xytext=(6, 3),
                        fontsize=8)
        ax.set_xscale("log")
        ax.set_xlabel("wall seconds, 12 frames (log)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("error against time")
    axes[1].set_title("flicker (frame-to-frame change error) against time")
    fig.text(0.5, 0.01, "\n".join(
        "   ".join(f"{n}: {p[0]}" for n, p in list(enumerate(POINTS, start=1))[i:i + 3])
        for i in range(0, len(POINTS), 3)), ha="center", va="bottom", fontsize=8)
    fig.suptitle("glossy Spheres 96x72, frames 0..11: temporal caching (blue circles) and "
                 "per-frame recomputation (orange squares); defaults outlined", fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 0.96))
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "spheres-glossy-front.png")
