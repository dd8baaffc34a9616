#!/usr/bin/env python3
"""Plot of sombra_bench_objects: plot_objects.py objects_table.csv out.png

Left (Knecht Fig. 5.13): DSM generation and camera-pass time against the number of steaming cups
N, one line per storage backend. Right (Tables 5.5-5.7): the same against the cloud's voxels per
side, with the mean nodes per texel on the right axis.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def series(rows, part, storage, column):
    picked = [r for r in rows if r["part"] == part and r["storage"] == storage]
    return [int(r["objects"].rstrip("³")) for r in picked], [float(r[column]) for r in picked]


def main(argv):
    if len(argv) != 3:
        sys.exit("usage: plot_objects.py objects_table.csv out.png")
    with open(argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    parts = sorted({r["part"] for r in rows}, reverse=True)  # cups, then cloud
    storages = sorted({r["storage"] for r in rows})
    fig, axes = plt.subplots(1, len(parts), figsize=(5.5 * len(parts), 4.2), dpi=120, squeeze=False)
    for ax, part in zip(axes[0], parts):
        for storage, colour in zip(storages, ["tab:blue", "tab:orange", "tab:green", "tab:red"]):
            x, gen = series(rows, part, storage, "dsm_generation_ms")
            ax.plot(x, gen, "o-", color=colour, label=f"DSM generation, {storage}")
            x, render = series(rows, part, storage, "render_ms")
            ax.plot(x, render, "s--", color=colour, label=f"camera pass, {storage}")
        ax.set_xlabel("steaming cups N" if part == "cups" else "cloud voxels per side")
        ax.set_ylabel("ms (median, PoCL)")
        ax.set_title("time against objects (Knecht Fig. 5.13)" if part == "cups" else "resolution classes (Tables 5.5-5.7)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
        nodes = ax.twinx()
        x, mean = series(rows, part, storages[0], "mean_nodes_per_texel")
        nodes.plot(x, mean, "k:", label="nodes per texel (mean)")
        nodes.set_ylabel("nodes per texel (mean)")
        nodes.set_ylim(bottom=0)
        nodes.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(argv[2])


if __name__ == "__main__":
    main(sys.argv)
