"""Low-pass (or SAT ambient occlusion) tables with cells fitted to the filter width (issue 30 item 1).

For each scene and filter width W, `sombra render SCENE --shadows lowpass --filter W` at SIZE² with
the shadow cache off, once with `--sat-cells-across 0` (every table cell one voxel, whatever W) and
once with the default 8 (W > 8 coarsens the cells across the light to W/8 voxels; with `--shadows
ao`, every cell of the volume-aligned table), `--runs` times
each, interleaved, in fresh processes: the median table build (the `sat_*`/`ssat_*` stages of
`--stats`), the median total, the tables' memory, and the image difference between the two (mean,
95th percentile and max over the pixels of the largest |ΔRGB| of the 8-bit PNGs). For scale, the
image difference of the voxel-cell tables between W and W + 1, and between the technique (W) and
shadow rays (its own departure from the unfiltered shadows).

usage: python3 bench/lowpass_cells_across.py [--shadows lowpass|ao] [--size 256] [--runs 3] [--widths 3,8,16,24]
                                             [--scenes default,smoke,head_in_fog,cup_array] [--out FILE]
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "view"))
from viewer import decode_png  # noqa: E402  (8-bit RGB PNGs, stdlib only)


def difference(a_path, b_path):
    """Mean, 95th percentile and max over the pixels of the largest |ΔRGB| of two PNGs sombra wrote."""
    (_, _, a), (_, _, b) = decode_png(Path(a_path).read_bytes()), decode_png(Path(b_path).read_bytes())
    d = sorted(max(abs(ra[3 * x + k] - rb[3 * x + k]) for k in range(3)) / 255.0 for ra, rb in zip(a, b) for x in range(len(ra) // 3))
    return sum(d) / len(d), d[int(0.95 * len(d))], d[-1]


def render(scene, size, out, stats, extra):
    command = [str(ROOT / "build" / "sombra"), "render", str(scene), "--width", str(size), "--height", str(size),
               "--shadow-cache", "off", "-q", "-o", str(out), "--stats", str(stats), *extra]
    subprocess.run(command, check=True)
    return json.loads(Path(stats).read_text())


def table_ms(stats):
    return sum(ms for stage, ms in stats["stage_ms"].items() if stage.startswith(("sat_", "ssat_")))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shadows", choices=["lowpass", "ao"], default="lowpass")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--widths", default="3,8,16,24")
    parser.add_argument("--scenes", default="default,smoke,head_in_fog,cup_array")
    parser.add_argument("--out")
    args = parser.parse_args()
    widths = [float(w) for w in args.widths.split(",")]
    lines = [f"`python3 bench/lowpass_cells_across.py --shadows {args.shadows} --size {args.size} --runs {args.runs} --widths {args.widths} "
             f"--scenes {args.scenes}`", "",
             "| scene | W | tables, voxel cells | tables, cells ≥ W/8 | total, voxel cells | total, cells ≥ W/8 "
             f"| memory | image \\|ΔRGB\\| mean / p95 / max | voxel cells W vs W + 1 | {args.shadows} vs shadow rays |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in args.scenes.split(","):
            scene = ROOT / "data" / "scenes" / f"{name}.json"
            render(scene, args.size, tmp / "rays.png", tmp / "rays.json", ["--shadows", "rays"])
            for width in widths:
                base = ["--shadows", args.shadows, "--filter", f"{width:g}"]
                runs = {"fine": [], "coarse": []}
                for _ in range(args.runs):  # interleaved
                    for mode, across in (("fine", "0"), ("coarse", "8")):
                        runs[mode].append(render(scene, args.size, tmp / f"{mode}.png", tmp / f"{mode}.json",
                                                 base + ["--sat-cells-across", across]))
                render(scene, args.size, tmp / "wider.png", tmp / "wider.json",
                       ["--shadows", args.shadows, "--filter", f"{width + 1:g}", "--sat-cells-across", "0"])
                mean, p95, worst = difference(tmp / "fine.png", tmp / "coarse.png")
                wider, rays = difference(tmp / "fine.png", tmp / "wider.png")[0], difference(tmp / "fine.png", tmp / "rays.png")[0]
                med = {mode: (statistics.median(table_ms(s) for s in r), statistics.median(s["total_ms"] for s in r))
                       for mode, r in runs.items()}
                mib = {mode: r[-1]["sat"]["bytes"] / 2**20 for mode, r in runs.items()}
                row = (f"| {name} | {width:g} | {med['fine'][0]:.0f} ms | {med['coarse'][0]:.0f} ms "
                       f"({med['fine'][0] / max(med['coarse'][0], 1e-9):.1f}×) | {med['fine'][1] / 1000:.2f} s "
                       f"| {med['coarse'][1] / 1000:.2f} s | {mib['fine']:.0f} → {mib['coarse']:.0f} MiB "
                       f"| {mean:.1e} / {p95:.1e} / {worst:.3f} | {wider:.1e} | {rays:.1e} |")
                lines.append(row)
                print(row, file=sys.stderr, flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
