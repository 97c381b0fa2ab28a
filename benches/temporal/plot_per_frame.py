#!/usr/bin/env python3
"""Per-frame indirect error of each variant, from saved `worst_frame.py` outputs: one panel
per file (its first line is the panel's title), a line per variant.

    python3 benches/temporal/plot_per_frame.py docs/images/temporal-horizon.png \\
        docs/data/temporal/lamp-switch-stop60.txt \\
        docs/data/temporal/cube-starts-stop60.txt \\
        docs/data/temporal/cube-in-box-anim-0-59-stop60.txt

Needs matplotlib (benches/peers/.venv has it).
"""
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker


def read(path):
    """(title, first frame, {variant: [indirect % per frame]}) of one worst_frame output."""
    lines = open(path).read().splitlines()
    title = lines[0]
    first = int(re.search(r"frames (\d+)\.\.", title).group(1))
    series = {}
    start = lines.index("per frame, indirect %:") + 1
    for line in lines[start:]:
        if not line.startswith("  "):
            break
        # worst_frame.py writes f"  {name:<22} " and the values.
        series[line[2:24].strip()] = [float(x) for x in line[25:].split()]
    return title, first, series


def main():
    out, paths = sys.argv[1], sys.argv[2:]
    fig, axes = plt.subplots(1, len(paths), figsize=(5.2 * len(paths), 3.8))
    if len(paths) == 1:
        axes = [axes]
    for ax, path in zip(axes, paths):
        title, first, series = read(path)
        scene = title.split()[0].rsplit("/", 1)[-1]
        for name, values in series.items():
            frames = range(first, first + len(values))
            ax.plot(frames, values, label=name, marker=".", markersize=3)
        ax.set_title(f"{scene} ({title.split(' at ')[1].split(',')[0]})", fontsize=10)
        ax.set_xlabel("frame")
        ax.set_ylabel("indirect error against the reference, %")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
