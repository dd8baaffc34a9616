#!/usr/bin/env python3
"""Plot of sombra_bench_lowpass: plot_lowpass.py lowpass_table_TAG.csv out.png

The low-pass box filter against the filter width W: render time per sample (no cache) and with the
cache, and the mean error (right axis). Error against time for every technique (the left panel this
plot had): sombra_bench_error, bench/plot_error_pareto.py.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = 5  # rows before the filter-width sweep (lowpass_bench.cpp: SS, AO, CS, FS box, FS gauss)


def main(argv):
    if len(argv) != 3:
        sys.exit("usage: plot_lowpass.py lowpass_table_TAG.csv out.png")
    csv_path, png_path = argv[1], argv[2]
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    widths = rows[METHODS:]
    fig, ax = plt.subplots(figsize=(6.5, 4.5), dpi=120)
    if widths:
        w = [float(r["filter"]) for r in widths]
        ax.plot(w, [float(r["uncached_render_ms"]) for r in widths], "o-", label="render per sample, ms")
        ax.plot(w, [float(r["render_ms"]) for r in widths], "s-", label="render with cache, ms")
        ax.set_xlabel("filter width W, voxels")
        ax.set_ylabel("ms")
        ax.set_ylim(bottom=0)
        twin = ax.twinx()
        twin.plot(w, [float(r["mean_abs_error"]) for r in widths], "^--", color="C3", label="mean |ΔT|")
        twin.set_ylabel("mean |ΔT| vs shadow rays")
        ax.legend(loc="upper left", fontsize=7)
        twin.legend(loc="upper right", fontsize=7)
    fig.suptitle(csv_path.rsplit("/", 1)[-1])
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(png_path)


if __name__ == "__main__":
    main(sys.argv)
