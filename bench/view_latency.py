#!/usr/bin/env python3
"""`sombra view`'s input-to-frame latency (issue 31 item 5): a scripted camera orbit with fixed lights
and a moving light with a fixed camera, as the page sends them (one request at a time, each waiting
for the previous frame), on the CT (data/scenes/default.json) and the smoke, with DSM and low-pass
shadows, at 256² (a progressive draft) and 512²
(the idle frame). Latency = request sent → PNG received (render, PNG encoding, base64, HTTP on
loopback); fps = frames ÷ wall time of the sequence. The first frame of each sequence (maps,
tables, programs) is reported apart as "first".

Usage: bench/view_latency.py [--frames N] [--out bench/results/view_latency.md] [--device cpu]
"""
import argparse
import json
import math
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "view"))
from viewer import ROOT, Viewer  # noqa: E402


def rotated(v, axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    k = [a / math.sqrt(sum(x * x for x in axis)) for a in axis]
    d = sum(a * b for a, b in zip(k, v))
    cr = [k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]]
    return [v[i] * c + cr[i] * s + k[i] * d * (1 - c) for i in range(3)]


def sequence(viewer, state, technique, motion, size, frames):
    camera, lights = dict(state["camera"]), [dict(l) for l in state["lights"]]
    options = {"shadows": technique, "width": size, "height": size}
    latencies, stats = [], []
    start = time.perf_counter()
    for k in range(frames + 1):
        angle = math.radians(5 * k)
        cam = dict(camera)
        light_fields = []
        if motion == "orbit":
            offset = [p - q for p, q in zip(camera["position"], camera["look_at"])]
            cam["position"] = [q + o for q, o in zip(camera["look_at"], rotated(offset, camera["up"], angle))]
        for i, l in enumerate(lights):
            fields = {}
            turn = motion == "light" and i == 0
            if "direction" in l:
                fields["direction"] = rotated(l["direction"], camera["up"], angle) if turn else l["direction"]
            if "position" in l:
                fields["position"] = rotated(l["position"], camera["up"], angle) if turn else l["position"]
            if turn and l["type"] == "spot":  # keep it aimed as it was, turned with its position
                fields["direction"] = rotated(l["direction"], camera["up"], angle)
            light_fields.append(fields)
        sent = time.perf_counter()
        status, body = viewer.post("/api/frame", {"options": options, "camera": cam, "lights": light_fields})
        if status != 200:
            raise RuntimeError(body.decode())
        latencies.append((time.perf_counter() - sent) * 1e3)
        stats.append(json.loads(body)["stats"])
        if k == 0:
            start = time.perf_counter()
    wall = time.perf_counter() - start
    rest = latencies[1:]
    rebuilt = sum(s.get("dsm", {}).get("views_generated", 0) for s in stats[1:])
    tables = sum(s.get("sat", {}).get("tables_built", 0) for s in stats[1:])
    return {"first": latencies[0], "median": statistics.median(rest), "max": max(rest), "fps": frames / wall,
            "rebuilt": f"{rebuilt} DSM views" if technique == "dsm" else f"{tables} tables",
            "camera": statistics.median(s["stage_ms"].get("camera_pass", 0) for s in stats[1:])}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "view_latency.md"))
    parser.add_argument("--device", default="auto")
    args = parser.parse_args()
    rows = []
    for name in ["default", "smoke"]:
        viewer = Viewer(os.path.join(ROOT, "data", "scenes", name + ".json"), "--quiet", "--device", args.device)
        try:
            state = json.loads(viewer.get("/api/state")[1])
            device = state["device"]
            for technique in ["dsm", "lowpass"]:
                for motion in ["orbit", "light"]:
                    for size in [256, 512]:
                        r = sequence(viewer, state, technique, motion, size, args.frames)
                        rows.append((name, technique, motion, size, r))
                        print(name, technique, motion, size, {k: (round(v, 1) if isinstance(v, float) else v) for k, v in r.items()},
                              flush=True)
        finally:
            viewer.close()
    lines = [f"# `sombra view` latency (bench/view_latency.py, {args.frames} frames per row after the first, {device})", "",
             "Each row: the first frame of the sequence (maps, tables and programs built), then "
             f"{args.frames} frames each turned 5° further (camera around its look-at point, or light 0 around the "
             "up axis): median and worst request-to-PNG latency on loopback, frames per second over the "
             "sequence, the camera pass's median kernel time, and what those frames rebuilt. The rows run in the "
             "order listed on one server per scene, so a row's first frame reuses what the rows before built "
             "(only each scene's first row compiles programs and prepares the scene). The shadow cache is on "
             "auto, which decides per frame: a row whose first frame found filling it too dear for one frame keeps "
             "it off for the whole sequence (the smoke's low-pass orbit at 256² is slower than at 512², where the "
             "cache was filled once and then read).", "",
             "| scene | technique | motion | size | first (ms) | median (ms) | max (ms) | fps | camera pass (ms) | rebuilt |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, technique, motion, size, r in rows:
        lines.append(f"| {'CT (default)' if name == 'default' else name} | {technique} | {motion} | {size}² | {r['first']:.0f} | "
                     f"{r['median']:.0f} | {r['max']:.0f} | {r['fps']:.2f} | {r['camera']:.0f} | {r['rebuilt']} |")
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("wrote " + args.out)


if __name__ == "__main__":
    main()
