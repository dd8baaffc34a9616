#!/usr/bin/env python3
"""Error against time for sombra_bench_error: plot_error_pareto.py error_table.csv out.png [title]

Two log-log panels, x the first-frame time in ms. Left: mean image |ΔRGB| against the converged
reference image, every row (filled markers: shadow cache off, hollow: on). Right: mean point |ΔT|
against reference_transmittance, the cache-off rows (the point query evaluates the technique
itself, never the cache). One colour and marker per technique; the Pareto front (the bench's
pareto_image / pareto_point columns) joined by a line and each of its points named.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402

STYLE = {  # technique: (colour, marker)
    "none": ("gray", "X"),
    "rays": ("black", "*"),
    "dsm": ("tab:blue", "o"),
    "shadowmap": ("tab:cyan", "s"),
    "lowpass": ("tab:orange", "D"),
    "ao": ("tab:green", "^"),
    "cone": ("tab:red", "v"),
}
FLOOR = 1e-6  # a zero error is drawn here (log scale)


def label(row):
    cache = " +cache" if row["shadow_cache"] == "on" else ""
    setting = "" if row["setting"] == "–" else " " + row["setting"]
    return f"{row['technique']}{setting}{cache}"


def panel(ax, rows, error, front_flag, ylabel):
    for technique, (colour, marker) in STYLE.items():
        for cache in ("off", "on", ""):
            pts = [r for r in rows if r["technique"] == technique and r["shadow_cache"] == cache]
            if not pts:
                continue
            ax.scatter([float(r["first_frame_ms"]) for r in pts], [max(float(r[error]), FLOOR) for r in pts],
                       marker=marker, s=60 if marker == "*" else 28, edgecolors=colour,
                       facecolors="none" if cache == "on" else colour, linewidths=1.0,
                       label=technique + (" (cache on)" if cache == "on" else ""))
    front = sorted((r for r in rows if r[front_flag] == "1"), key=lambda r: float(r["first_frame_ms"]))
    if front:
        xs, ys = [float(r["first_frame_ms"]) for r in front], [max(float(r[error]), FLOOR) for r in front]
        ax.plot(xs, ys, color="crimson", linewidth=1.4, alpha=0.7, drawstyle="steps-post", zorder=0, label="Pareto front")
        ax.scatter(xs, ys, s=150, facecolors="none", edgecolors="crimson", linewidths=1.2, zorder=3)
        offsets = ((10, 8), (10, -16), (10, 24))  # neighbours on the front take turns, tied by a leader line
        for i, (x, y, r) in enumerate(zip(xs, ys, front)):
            ax.annotate(label(r), (x, y), textcoords="offset points", xytext=offsets[i % len(offsets)], fontsize=7,
                        color="crimson", arrowprops=dict(arrowstyle="-", color="crimson", linewidth=0.5, alpha=0.6))
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(plain)
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("first-frame time, ms (log): build + cache fill + camera pass")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", linewidth=0.3)


def main(csv_path, png_path, title):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    fig, (left, right) = plt.subplots(1, 2, figsize=(15, 6.5), dpi=110)
    panel(left, rows, "image_mean", "pareto_image", "mean image |ΔRGB| vs converged shadow rays (log)")
    left.set_title("image error, every configuration")
    panel(right, [r for r in rows if r["shadow_cache"] != "on"], "point_mean", "pareto_point",
          "mean |ΔT| vs reference_transmittance (log)")
    right.set_title("point error, cache off (the query never reads the cache)")
    handles, labels = left.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 7), fontsize=8, frameon=False)
    fig.suptitle(f"sombra: error against time — {title}" if title else "sombra: error against time")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(png_path)


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit("usage: plot_error_pareto.py error_table.csv out.png [title]")
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) == 4 else "")
