"""Pinned against unpinned PoCL threads (POCL_AFFINITY=1), interleaved (bench/README.md "At least four
blocks along each axis").

Per cell (scene x technique x size), `repeats` rounds; in each, both settings render the frame with
`--shadow-cache off`, `on` and `auto` (history off: auto probes, as a first run does), each in a fresh
`sombra render` process. Prints, per cell and setting, the median stats total_ms of each mode and auto
/ the faster of on and off; at the end, cells within 1.10x and the pinned / unpinned medians.

usage: python3 bench/pocl_affinity_ab.py [--sizes 128,256] [--repeats 3] [--scenes a,b] [--jsonl FILE]
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SETTINGS = {"unpinned": {}, "pinned": {"POCL_AFFINITY": "1"}}
MODES = ("off", "on", "auto")


def frame_ms(scene, technique, size, mode, env, folder):
    stats = Path(folder) / "stats.json"
    command = [str(ROOT / "build" / "sombra"), "render", str(ROOT / "data" / "scenes" / f"{scene}.json"), "--shadows", technique,
               "--width", str(size), "--height", str(size), "-o", str(Path(folder) / "frame.png"), "--stats", str(stats), "-q",
               "--shadow-cache", mode]
    done = subprocess.run(command, env={**os.environ, "SOMBRA_AUTO_HISTORY": "off", **env}, capture_output=True)
    return json.loads(stats.read_text())["total_ms"] if done.returncode == 0 else None


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="128,256")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenes", default="vdb_smoke,steaming_cups,two_smokes_wall,teapot_fog,cup_array")
    parser.add_argument("--techniques", default="dsm,shadowmap,rays,lowpass,ao,cone")
    parser.add_argument("--jsonl", default="")
    args = parser.parse_args()
    records = []
    with tempfile.TemporaryDirectory() as folder:
        for scene in args.scenes.split(","):
            for technique in args.techniques.split(","):
                for size in (int(s) for s in args.sizes.split(",")):
                    times = {f"{setting}/{mode}": [] for setting in SETTINGS for mode in MODES}
                    for _ in range(args.repeats):
                        for setting, env in SETTINGS.items():
                            for mode in MODES:
                                ms = frame_ms(scene, technique, size, mode, env, folder)
                                if ms is not None:
                                    times[f"{setting}/{mode}"].append(ms)
                    if not all(times.values()):
                        print(f"| {scene} | {technique} | {size} | not supported |", flush=True)
                        continue
                    median = {key: statistics.median(values) for key, values in times.items()}
                    records.append({"scene": scene, "technique": technique, "size": size, "times": times})
                    cells = " | ".join(f"{median[s + '/off']:.0f} | {median[s + '/on']:.0f} | {median[s + '/auto']:.0f} | "
                                       f"{median[s + '/auto'] / min(median[s + '/off'], median[s + '/on']):.2f}" for s in SETTINGS)
                    print(f"| {scene} | {technique} | {size} | {cells} |", flush=True)
    if args.jsonl:
        Path(args.jsonl).write_text("".join(json.dumps(r) + "\n" for r in records))
    for setting in SETTINGS:
        ratios = [statistics.median(r["times"][f"{setting}/auto"]) /
                  min(statistics.median(r["times"][f"{setting}/off"]), statistics.median(r["times"][f"{setting}/on"])) for r in records]
        print(f"{setting}: auto within 1.10x in {sum(x <= 1.10 for x in ratios)} of {len(ratios)} cells, worst {max(ratios):.2f}x")
    for mode in MODES:
        logs = sorted(math.log(statistics.median(r["times"][f"pinned/{mode}"]) / statistics.median(r["times"][f"unpinned/{mode}"]))
                      for r in records)
        pick = lambda q: math.exp(logs[min(len(logs) - 1, int(q * len(logs)))])
        print(f"{mode}: pinned / unpinned, median {math.exp(statistics.median(logs)):.3f} (10th-90th percentile {pick(0.1):.2f}-{pick(0.9):.2f})")


if __name__ == "__main__":
    main()
