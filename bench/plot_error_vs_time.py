#!/usr/bin/env python3
"""Error against time for sombra_bench_dsm: plot_error_vs_time.py dsm_table.csv out.png

x: time per frame in ms, log scale (DSM rows: generation + camera pass; shadow rays: camera pass).
y: mean |T - T_reference| over the bench's random points, log scale. One marker series per DSM
storage and resolution (joined in epsilon order, smallest and largest epsilon labelled), one point
for shadow rays, and the no-shadow render time as a dashed vertical line.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402


def main(csv_path, png_path):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    series = {}
    for r in rows:
        if r["shadows"] == "dsm":
            key = (r["storage"], int(r["resolution"]))
            series.setdefault(key, []).append((float(r["total_ms"]), float(r["mean_abs_error"]), r["epsilon"]))

    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=120)
    markers = "osD^v<>ph*"
    for i, ((storage, res), pts) in enumerate(sorted(series.items())):
        pts.sort(key=lambda p: float(p[2]))
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        label = f"DSM {res}²" + (f" ({storage})" if len({k[0] for k in series}) > 1 else "")
        ax.plot(xs, ys, marker=markers[i % len(markers)], linestyle="-", linewidth=0.8, label=label)
        for x, y, eps in (pts[0], pts[-1]) if len(pts) > 1 else pts:  # the line runs in ε order between them
            ax.annotate(f"ε={eps}", (x, y), textcoords="offset points", xytext=(4, 3), fontsize=7, alpha=0.8)
    for r in rows:
        if r["shadows"] == "rays":
            ax.plot([float(r["render_ms"])], [float(r["mean_abs_error"])], marker="*", markersize=14,
                    color="black", linestyle="none", label="shadow rays (render)")
        elif r["shadows"] == "none":
            ax.axvline(float(r["render_ms"]), color="gray", linestyle="--", linewidth=0.8,
                       label="no shadows (render time)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    for axis in (ax.xaxis, ax.yaxis):  # 1-2-5 ticks, plain numbers
        axis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(plain)
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("time per frame, ms (log scale): DSM generation + render; shadow rays: render")
    ax.set_ylabel("mean |T − T_reference| over the points (log scale)")
    ax.set_title("sombra: deep shadow maps vs shadow rays — error against time")
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: plot_error_vs_time.py dsm_table.csv out.png")
    main(sys.argv[1], sys.argv[2])
