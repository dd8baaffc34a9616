"""Distributed rendering over MPI (issue 32): per-rank stage times, bytes exchanged and peak memory
for N = 1, 2, 4 ranks, and the bytes of maps against --dsm-res and --eps.

For each scene and N, `mpirun -np N sombra render SCENE --distributed --stats` at SIZE², `--runs`
times after one warm-up (compiled programs then come from the on-disk cache); per N the median of
rank 0's wall time of the whole process and, from its stats, every rank's stage times (kernel
times from OpenCL profiling events), its map bytes sent and received, image bytes sent to rank 0,
peak resident memory and region voxels. On a machine of 2 cores, N > 2 ranks share them: the
per-rank work (summed over ranks) and the bytes are what these runs measure; docs/distributed.md
models time and traffic for more ranks from them.

usage: python3 bench/distributed.py [--size 128] [--runs 3] [--scenes default,smoke] [--out FILE]
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
STAGES = ["distributed_split", "dsm_build", "dsm_exchange", "camera_pass", "distributed_composite"]


def render(scene, ranks, size, work, extra=()):
    stats = Path(work) / "stats.json"
    command = [shutil.which("mpirun") or "mpirun", "--oversubscribe", "-np", str(ranks), str(ROOT / "build" / "sombra"), "render",
               str(scene), "--distributed", "--width", str(size), "--height", str(size), "-q",
               "-o", str(Path(work) / "out.png"), "--stats", str(stats), *extra]
    start = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, env=ENV)
    wall_ms = (time.monotonic() - start) * 1e3
    if done.returncode != 0:
        sys.exit(f"distributed: {' '.join(command)} failed: {done.stderr.strip()[-400:]}")
    return wall_ms, json.loads(stats.read_text())["distributed"]["per_rank"]


def mib(b):
    return f"{b / 2**20:.1f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenes", default="default,smoke")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    lines = [f"Distributed renders at {args.size}², PoCL, 2 cores; median of {args.runs} runs after a warm-up "
             "(`bench/distributed.py`). Per rank: max over the ranks (sum in brackets) of the stage in ms; "
             "bytes per rank (max); memory: peak resident set of the largest rank.", ""]
    with tempfile.TemporaryDirectory() as work:
        for name in args.scenes.split(","):
            scene = ROOT / "data" / "scenes" / f"{name}.json"
            lines += [f"### {name}", "",
                      "| N | wall ms (rank 0 process) | " + " | ".join(STAGES) +
                      " | map MiB sent | map MiB received | image MiB to rank 0 | region voxels (max) | peak MiB |",
                      "|---|---|" + "---|" * (len(STAGES) + 5)]
            for ranks in (1, 2, 4):
                render(scene, ranks, args.size, work)  # warm-up
                runs = [render(scene, ranks, args.size, work) for _ in range(args.runs)]
                wall = statistics.median(r[0] for r in runs)
                per_rank = runs[len(runs) // 2][1]
                cells = []
                for stage in STAGES:
                    medians = [statistics.median(r[1][k]["stage_ms"].get(stage, 0.0) for r in runs) for k in range(ranks)]
                    cells.append(f"{max(medians):.0f} ({sum(medians):.0f})")
                d = [p["distributed"] for p in per_rank]
                lines.append(f"| {ranks} | {wall:.0f} | " + " | ".join(cells) +
                             f" | {mib(max(x['map_bytes_sent'] for x in d))} | {mib(max(x['map_bytes_received'] for x in d))}"
                             f" | {mib(max(x['image_bytes_sent'] for x in d))} | {max(x['region_voxels'] for x in d):,}"
                             f" | {mib(max(x['peak_memory_bytes'] for x in d))} |")
                print(lines[-1], flush=True)
            lines.append("")
        # map bytes against resolution and ε: 2 ranks, the first scene
        scene = ROOT / "data" / "scenes" / f"{args.scenes.split(',')[0]}.json"
        lines += [f"### Map bytes per rank against --dsm-res and --eps ({scene.stem}, 2 ranks)", "",
                  "| --dsm-res | --eps | MiB sent (max rank) | nodes (max rank) | texel offsets MiB (4 B · res² · views) |", "|---|---|---|---|---|"]
        for res in (256, 512, 1024):
            for eps in (0.01, 0.05):
                _, per_rank = render(scene, 2, args.size, work, ("--dsm-res", str(res), "--eps", str(eps)))
                sent = max(p["distributed"]["map_bytes_sent"] for p in per_rank)
                nodes = max(p["dsm"]["nodes"] for p in per_rank)
                views = per_rank[0]["dsm"]["views"]
                lines.append(f"| {res} | {eps} | {mib(sent)} | {nodes:,} | {mib(4 * res * res * views)} |")
                print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
