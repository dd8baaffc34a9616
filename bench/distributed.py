"""Distributed rendering over MPI (issue 32): per-rank stage times, bytes exchanged and peak memory
for N = 1, 2, 4 ranks, and the bytes of maps against --dsm-res and --eps.

For each scene and N, `mpirun -np N sombra render SCENE --distributed --stats` at SIZE², `--runs`
times after one warm-up (compiled programs then come from the on-disk cache); per N the median of
rank 0's wall time of the whole process and, from its stats, every rank's stage times (kernel
times from OpenCL profiling events), its map bytes sent and received, image bytes sent to rank 0,
peak resident memory and region voxels. On a machine of 2 cores, N > 2 ranks share them: the
per-rank work (summed over ranks) and the bytes are what these runs measure; docs/distributed.md
models time and traffic for more ranks from them.

usage: python3 bench/distributed.py [--size 128] [--runs 3] [--scenes cloud384,cloud384.nrrd,default] [--out FILE]
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
STAGES = ["distributed_region", "dsm_build", "dsm_exchange_send", "dsm_exchange_wait", "dsm_exchange_gather", "dsm_exchange_merge",
          "camera_pass", "distributed_composite"]


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


def cloud_scene(size, folder, nrrd=False):
    """A SIZE³ uint8 .npy cloud (a few Gaussian blobs and noise; fixed seed), or the same voxels as a
    gzip NRRD, and a scene file that renders it: ranks read only their box of it."""
    import numpy as np
    rng = np.random.default_rng(5)
    axis = np.linspace(-1, 1, size, dtype=np.float32)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij", sparse=True)
    density = np.zeros((size, size, size), dtype=np.float32)
    for _ in range(6):
        c = rng.uniform(-0.45, 0.45, 3).astype(np.float32)
        r = np.float32(rng.uniform(0.25, 0.45))
        density += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / (2 * r * r))
    density *= np.float32(0.75) + np.float32(0.5) * rng.random(density.shape, dtype=np.float32)
    voxels = np.clip(density * 120, 0, 255).astype(np.uint8)
    name = f"cloud{size}.nrrd" if nrrd else f"cloud{size}.npy"
    if nrrd:  # x fastest, as NRRD stores it: the array's C order (z, y, x)
        import gzip
        header = f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {size} {size} {size}\nspacings: 1 1 1\nencoding: gzip\n\n"
        (Path(folder) / name).write_bytes(header.encode() + gzip.compress(voxels.tobytes(), 6))
    else:
        np.save(Path(folder) / name, voxels)
    scene = {
        "camera": {"position": [1.6 * size, -1.4 * size, 0.9 * size], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 40},
        "background": [0.55, 0.6, 0.7],
        "volumes": [{"name": "cloud", "file": name, "step_voxels": 0.75, "opacity_unit": 4,
                     "transfer_function": {"rgb_points": [0, 0.85, 0.85, 0.9, 255, 1, 1, 1],
                                           "opacity_points": [0, 0, 60, 0, 160, 0.3, 255, 0.7]},
                     "material": {"ambient": 1.0, "diffuse": 1.0, "specular": 0.0, "shininess": 1}}],
        "lights": [{"type": "directional", "direction": [0.6, 0.3, -0.75], "intensity": 1.2},
                   {"type": "point", "position": [-0.8 * size, 0.7 * size, size], "color": [1, 0.8, 0.6], "intensity": 0.8}],
    }
    path = Path(folder) / (name.replace(".", "_") + ".json")
    path.write_text(json.dumps(scene, indent=1))
    return path


def mib(b):
    return f"{b / 2**20:.1f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenes", default="cloud384,default,smoke",
                        help="shipped scenes by name; cloudN: a generated N³ .npy cloud, cloudN.nrrd: the same "
                             "as a gzip NRRD (both read in parts)")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    lines = [f"Distributed renders at {args.size}², PoCL, 2 cores; median of {args.runs} runs after a warm-up "
             "(`bench/distributed.py`). Per stage: the slowest rank's ms (the sum over ranks in brackets); "
             "distributed_region: the split and reading (or cropping) the rank's box; dsm_exchange_wait: waiting "
             "for the slowest rank's maps; dsm_exchange_send: reading back and serializing a rank's maps; _gather: "
             "MPI_Allgatherv; _merge: checking, merging and uploading every rank's. "
             "Bytes and memory: the largest rank's (memory: peak resident set).", ""]
    scenes = {}
    with tempfile.TemporaryDirectory() as work:
        for name in args.scenes.split(","):
            scene = (cloud_scene(int(name[5:].removesuffix(".nrrd")), work, name.endswith(".nrrd")) if name.startswith("cloud")
                     else ROOT / "data" / "scenes" / f"{name}.json")
            scenes[name] = scene
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
        scene = scenes[args.scenes.split(",")[0]]
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
    publish("\n".join(lines) + "\n", args.out)


def publish(text, out):
    """The table on stdout, and in `out` when given."""
    print(text)
    if out:
        Path(out).write_text(text)


if __name__ == "__main__":
    main()
