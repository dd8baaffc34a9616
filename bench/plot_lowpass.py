#!/usr/bin/env python3
"""Plots of sombra_bench_lowpass: plot_lowpass.py lowpass_table_TAG.csv out.png

Left: mean |T - T_shadow rays| against the time per frame of each table method (Ament Table 1
methods), once with the shadow cache (camera pass + rebuild after one light moved, open markers)
and once per sample (no cache, filled markers); shadow rays' render time as a dashed line.
Right: the low-pass box filter against the filter width W: render time per sample (no cache) and
with the cache, and the mean error (right axis).
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
    methods, widths = rows[:METHODS], rows[METHODS:]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), dpi=120)
    for i, r in enumerate(methods):
        if r["method"].startswith("SS"):
            left.axvline(float(r["render_ms"]), color="grey", linestyle="--", label="SS (shadow rays) render")
            continue
        error = max(float(r["mean_abs_error"]), 1e-6)
        colour = "C%d" % i
        left.scatter(float(r["render_ms"]) + float(r["light_move_ms"]), error, marker="o", facecolors="none",
                     edgecolors=colour, label=r["method"] + ": cache, after a light move")
        left.scatter(float(r["uncached_render_ms"]), error, marker="o", color=colour, label=r["method"] + ": per sample")
    left.set_xscale("log")
    left.set_yscale("log")
    left.set_xlabel("time per frame, ms")
    left.set_ylabel("mean |ΔT| vs shadow rays")
    left.legend(fontsize=6)
    if widths:
        w = [float(r["filter"]) for r in widths]
        right.plot(w, [float(r["uncached_render_ms"]) for r in widths], "o-", label="render per sample, ms")
        right.plot(w, [float(r["render_ms"]) for r in widths], "s-", label="render with cache, ms")
        right.set_xlabel("filter width W, voxels")
        right.set_ylabel("ms")
        right.set_ylim(bottom=0)
        twin = right.twinx()
        twin.plot(w, [float(r["mean_abs_error"]) for r in widths], "^--", color="C3", label="mean |ΔT|")
        twin.set_ylabel("mean |ΔT| vs shadow rays")
        right.legend(loc="upper left", fontsize=7)
        twin.legend(loc="upper right", fontsize=7)
    fig.suptitle(csv_path.rsplit("/", 1)[-1])
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(png_path)


if __name__ == "__main__":
    main(sys.argv)
