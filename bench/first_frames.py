"""First frames of every technique on every shipped scene, against deep shadow maps (issue 30 item 3).

For each scene in data/scenes/ and each technique, `sombra render SCENE --shadows T` at SIZE² in a
fresh process (nothing kept: a user's first frame; compiled programs come from the on-disk cache,
filled by warm-up runs of each cell with the shadow cache auto, on and off at 32² and auto at SIZE²), `--runs` times; the median of the process's own total
(`--stats` total_ms: preparation, tables or maps, camera pass, without process start) and the
ratio to DSM's median on the same scene. Runs of one scene are interleaved technique by technique,
so that load on the machine falls on every column alike. Writes a markdown table (stdout, and
--out) with the slowest stage of each cell and whether it is within 2x of DSM.

usage: python3 bench/first_frames.py [--size 256] [--runs 3] [--scenes smoke,default] [--techniques rays,rays:--ray-cache-lattice=volume] [--out FILE]
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TECHNIQUES = ["dsm", "rays", "shadowmap", "lowpass", "ao", "cone"]


def render(scene, technique, size, stats_path, extra=()):
    # a column "rays:--ray-cache-lattice=volume": the technique with options of its own
    technique, *options = technique.split(":")
    extra = tuple(part for option in options for part in option.split("=", 1)) + tuple(extra)
    command = [str(ROOT / "build" / "sombra"), "render", str(scene), "--shadows", technique, "--width", str(size),
               "--height", str(size), "-o", str(Path(stats_path).with_suffix(".png")), "--stats", str(stats_path), *extra]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode == 1 and "not supported by --shadows" in done.stderr:
        return None  # a combination the scene refuses (e.g. polyhedral bounds with the low-pass family)
    if done.returncode != 0:
        sys.exit(f"first_frames: {' '.join(command)} failed: {done.stderr.strip().splitlines()[-1:]}")
    return json.loads(Path(stats_path).read_text())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenes", default="", help="comma-separated names without .json (default: all shipped)")
    parser.add_argument("--techniques", default="", help="comma-separated (default: all six; dsm is always run); "
                        "a technique with options of its own: rays:--ray-cache-lattice=volume")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    global TECHNIQUES
    if args.techniques:
        TECHNIQUES = ["dsm"] + [t for t in args.techniques.split(",") if t != "dsm"]
    scenes = sorted((ROOT / "data" / "scenes").glob("*.json"))
    if args.scenes:
        wanted = set(args.scenes.split(","))
        scenes = [s for s in scenes if s.stem in wanted]
    lines = [f"First frames at {args.size}², median of {args.runs} fresh processes (`--stats` total_ms), "
             f"ratio to DSM on the same scene; goal (issue 30): every cell ≤ 2× DSM.", "",
             "| scene | " + " | ".join(TECHNIQUES) + " | slowest stage of the slowest technique |",
             "|---|" + "---|" * (len(TECHNIQUES) + 1)]
    misses = []
    with tempfile.TemporaryDirectory() as folder:
        stats_path = Path(folder) / "stats.json"
        for scene in scenes:
            # warm-up: compiles the programs into the on-disk cache, with the shadow cache on and off
            # (auto may choose either in a timed run); None: the scene refuses the technique
            # (32²: the programs do not depend on the image size)
            techniques = [t for t in TECHNIQUES if render(scene, t, 32, stats_path) is not None]
            for t in techniques:
                for mode in ("on", "off"):
                    render(scene, t, 32, stats_path, ("--shadow-cache", mode))
                # and once at the timed size: whether the meshes' surface shadow cache pays (another
                # program) depends on the fragments, so on the image size
                render(scene, t, args.size, stats_path)
            totals = {t: [] for t in techniques}
            stages = {}
            compiled = set()  # cells whose timed runs compiled a program anyway (marked *)
            for _ in range(args.runs):
                for technique in techniques:
                    stats = render(scene, technique, args.size, stats_path)
                    totals[technique].append(stats["total_ms"])
                    if stats.get("programs", {}).get("compiled", 0):
                        compiled.add(technique)
                    stages[technique] = stats["stage_ms"]
            median = {t: statistics.median(v) for t, v in totals.items()}
            cells = []
            for t in TECHNIQUES:
                if t not in median:
                    cells.append("not supported")
                    continue
                ratio = median[t] / median["dsm"]
                if ratio > 2:
                    misses.append(f"{scene.stem}/{t}")
                cells.append(f"{median[t] / 1e3:.2f} s ({ratio:.1f}×)" + ("*" if t in compiled else ""))
            slowest = max(techniques, key=lambda t: median[t])
            stage, ms = max(stages[slowest].items(), key=lambda kv: kv[1])
            lines.append(f"| {scene.stem} | " + " | ".join(cells) + f" | {slowest}: {stage} {ms / 1e3:.2f} s |")
            print(lines[-1], file=sys.stderr)
    lines += ["", "Cells over 2× DSM: " + (", ".join(misses) if misses else "none") + ".",
              "*: a timed run compiled a program (not in the cache after the warm-up)."]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
