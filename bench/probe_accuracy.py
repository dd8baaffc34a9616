"""How far auto's probe is from the frame it estimates (issue 29 item 5; docs/shadows.md "Auto").

The shadow cache's auto (src/render/shadow_cache.cpp probe_volume_costs) estimates three costs from
small runs of the real kernels: the fill of the lattices, the camera pass evaluating the technique
per sample, and the camera pass reading the cache. This script measures each estimate against the
stage it estimates, on the shipped scenes. Per cell (scene x technique x size), each in a fresh
`sombra render` process with auto's history off:

- `--shadow-cache off`: the per-sample camera pass (stage camera_pass);
- `--shadow-cache on --shadow-cache-fill all`: the fill of all points (stage shadow_cache) and the
  cached camera pass;
- `--shadow-cache on`: the visible fill (marking pass, fill of the marked points, camera pass);
- `--probes` auto frames with SOMBRA_AUTO_PROBE_ALL=1, which runs every stage of the probe whatever
  the earlier stages found and reports each in --stats (shadow_cache.auto.stages).

Tables (stdout and --out): each stage's estimate / actual (median factor, 10th-90th percentile),
and the error of the ratio the choice rests on, per-sample pass / (fill + cached pass), for each
pair of camera stage and fill stage. Raw records go to --jsonl; --from re-reads such a file instead
of rendering.

usage: python3 bench/probe_accuracy.py [--sizes 128,256] [--scenes smoke,teapot_fog] [--techniques cone,rays]
                                       [--probes 2] [--slow-ms 8000] [--jsonl FILE] [--from FILE] [--out FILE]
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TECHNIQUES = ["dsm", "shadowmap", "rays", "lowpass", "ao", "cone"]


def render(scene, technique, size, stats_path, extra=(), env=None):
    command = [str(ROOT / "build" / "sombra"), "render", str(scene), "--shadows", technique, "--width", str(size), "--height",
               str(size), "-o", str(Path(stats_path).with_suffix(".png")), "--stats", str(stats_path), "-q", *extra]
    done = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "SOMBRA_AUTO_HISTORY": "off", **(env or {})})
    if done.returncode != 0:
        return None, done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed"
    return json.loads(Path(stats_path).read_text()), None


def measure_cell(scene, technique, size, probes, slow_ms, stats_path):
    record = {"scene": scene.stem, "technique": technique, "size": size}
    off, error = render(scene, technique, size, stats_path, ("--shadow-cache", "off"))
    if error:
        return {**record, "error": error}
    record["off"] = {"camera_pass": off["stage_ms"].get("camera_pass", 0)}
    if record["off"]["camera_pass"] > slow_ms:
        return {**record, "error": "per-sample pass over --slow-ms"}
    every, _ = render(scene, technique, size, stats_path, ("--shadow-cache", "on", "--shadow-cache-fill", "all"))
    visible, _ = render(scene, technique, size, stats_path, ("--shadow-cache", "on"))
    record["all"] = {"fill": every["stage_ms"].get("shadow_cache", 0), "camera_pass": every["stage_ms"].get("camera_pass", 0)}
    record["on"] = {"mark": visible["stage_ms"].get("shadow_cache_mark", 0), "fill": visible["stage_ms"].get("shadow_cache", 0),
                    "camera_pass": visible["stage_ms"].get("camera_pass", 0)}
    record["probes"] = []
    for _ in range(probes):
        stats, _ = render(scene, technique, size, stats_path, ("--shadow-cache", "auto"), {"SOMBRA_AUTO_PROBE_ALL": "1"})
        record["probes"].append(stats.get("shadow_cache", {}).get("auto", {}).get("stages", []))
    return record


def actual(record, quantity):
    return {"fill": record["all"]["fill"], "cached": record["all"]["camera_pass"], "per_sample": record["off"]["camera_pass"]}[quantity]


def actual_ratio(record):
    """The ratio auto chooses by, per-sample pass ÷ (fill + cached pass), from the frames' own stages."""
    return record["off"]["camera_pass"] / (record["all"]["fill"] + record["all"]["camera_pass"])


def factor_row(logs):
    logs = sorted(logs)
    pick = lambda q: math.exp(logs[min(len(logs) - 1, int(q * len(logs)))])
    return f"{math.exp(statistics.median(logs)):.2f} | {pick(0.1):.2f}–{pick(0.9):.2f} | {len(logs)}"


def tables(records):
    usable = [r for r in records if "probes" in r and r["all"]["fill"] > 0 and r["all"]["camera_pass"] > 0 and r["off"]["camera_pass"] > 0]
    lines = [f"{len(usable)} cells, {sum(len(r['probes']) for r in usable)} probes\n",
             "| estimates | stage | estimate ÷ actual, median | 10th–90th percentile | probes |", "|---|---|---|---|---|"]
    per_stage = {}
    for r in usable:
        for probe in r["probes"]:
            for s in probe:
                if s["estimate_ms"] > 0:
                    per_stage.setdefault((s["quantity"], s["stage"]), []).append(math.log(s["estimate_ms"] / actual(r, s["quantity"])))
    for (quantity, stage), logs in sorted(per_stage.items()):
        lines.append(f"| {quantity} | {stage} | {factor_row(logs)} |")
    lines += ["", "The ratio auto chooses by, per-sample pass ÷ (fill + cached pass): estimated ÷ actual",
              "", "| camera stage | fill stage | median | 10th–90th percentile | probes | off by more than 1.35× |", "|---|---|---|---|---|---|"]
    ratio = {}
    for r in usable:
        truth = actual_ratio(r)
        for probe in r["probes"]:
            by = {(s["quantity"], s["stage"]): s["estimate_ms"] for s in probe}
            fills = [stage for quantity, stage in by if quantity == "fill"]
            for camera in ("launch 1", "launch 4"):
                if ("per_sample", camera) not in by:
                    continue
                for fill in fills:
                    estimated = by[("per_sample", camera)] / (by[("fill", fill)] + by[("cached", camera)])
                    if estimated > 0:
                        ratio.setdefault((camera, fill), []).append(math.log(estimated / truth))
    for (camera, fill), logs in sorted(ratio.items()):
        off = sum(abs(x) > math.log(1.35) for x in logs)
        lines.append(f"| {camera} | {fill} | {factor_row(logs)} | {off} |")
    # per technique: whether a calibration per technique (one factor each) could take out the
    # estimates' excess, or whether the scenes' spread within a technique is as wide
    lines += ["", "Per technique (launch 4, fill blocks 2 every 32): estimate ÷ actual, median and the scenes' lowest–highest",
              "", "| technique | per-sample pass | cached pass | fill of every point | ratio per sample ÷ (fill + cached) | cells |",
              "|---|---|---|---|---|---|"]
    for technique in TECHNIQUES:
        factors = {"per_sample": [], "cached": [], "fill": [], "ratio": []}
        for r in usable:
            if r["technique"] != technique:
                continue
            by = {(s["quantity"], s["stage"]): s["estimate_ms"] for s in r["probes"][0]}
            keys = (("per_sample", "launch 4"), ("cached", "launch 4"), ("fill", "blocks 2 every 32"))
            if not all(by.get(k, 0) > 0 for k in keys):
                continue
            per_sample, cached, fill = (by[k] for k in keys)
            factors["per_sample"].append(per_sample / actual(r, "per_sample"))
            factors["cached"].append(cached / actual(r, "cached"))
            factors["fill"].append(fill / actual(r, "fill"))
            truth = actual_ratio(r)
            factors["ratio"].append(per_sample / (fill + cached) / truth)
        if factors["ratio"]:
            cell = lambda v: f"{statistics.median(v):.2f} ({min(v):.2f}–{max(v):.2f})"
            lines.append(f"| {technique} | {cell(factors['per_sample'])} | {cell(factors['cached'])} | {cell(factors['fill'])} | "
                         f"{cell(factors['ratio'])} | {len(factors['ratio'])} |")
    lines += ["", "Choices replayed from these stages: the first camera launch and the coarse fill (blocks 2 every 64) decide",
              "when one side costs 3x the other, else the fill stage below does; the cache when 1.1 x (fill + cached) < per sample,",
              "marking when 2 x cached < fill. The chosen mode's actual stages plus the probe stages' kernel time, against the",
              "fastest of off, on filling all points and on marking (actual stages):",
              "", "| fill stage after the coarse one | within 1.10x of the fastest | probes |", "|---|---|---|"]
    for fill in ("blocks 2 every 32", "blocks 4 every 64", "blocks 4 every 32", "blocks 8 every 64"):
        within = total = 0
        for r in usable:
            best = min(r["off"]["camera_pass"], r["all"]["fill"] + r["all"]["camera_pass"], r["on"]["mark"] + r["on"]["fill"] + r["on"]["camera_pass"])
            for probe in r["probes"]:
                by = {(s["quantity"], s["stage"]): s for s in probe}
                if not all(k in by for k in (("per_sample", "launch 1"), ("fill", "blocks 2 every 64"), ("fill", fill))):
                    continue
                per_sample, cached, coarse = by[("per_sample", "launch 1")], by[("cached", "launch 1")], by[("fill", "blocks 2 every 64")]
                spent = per_sample["ms"] + cached["ms"] + coarse["ms"]
                fill_ms = coarse["estimate_ms"]
                if not (3 * per_sample["estimate_ms"] < fill_ms + cached["estimate_ms"] or per_sample["estimate_ms"] > 3 * (fill_ms + cached["estimate_ms"])):
                    fill_ms = by[("fill", fill)]["estimate_ms"]
                    spent += by[("fill", fill)]["ms"]
                if 1.1 * (fill_ms + cached["estimate_ms"]) < per_sample["estimate_ms"]:
                    marks = 2 * cached["estimate_ms"] < fill_ms
                    chosen = r["on"]["mark"] + r["on"]["fill"] + r["on"]["camera_pass"] if marks else r["all"]["fill"] + r["all"]["camera_pass"]
                else:
                    chosen = r["off"]["camera_pass"]
                total += 1
                within += chosen + spent <= 1.1 * best
        lines.append(f"| {fill} | {within} | {total} |")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="128,256")
    parser.add_argument("--scenes", default="")
    parser.add_argument("--techniques", default=",".join(TECHNIQUES))
    parser.add_argument("--probes", type=int, default=2)
    parser.add_argument("--slow-ms", type=float, default=8000)
    parser.add_argument("--jsonl", default="")
    parser.add_argument("--from", dest="source", default="")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    if args.source:
        records = [json.loads(line) for line in Path(args.source).read_text().splitlines() if line.strip()]
    else:
        scenes = sorted((ROOT / "data" / "scenes").glob("*.json"))
        if args.scenes:
            scenes = [ROOT / "data" / "scenes" / f"{name}.json" for name in args.scenes.split(",")]
        records = []
        with tempfile.TemporaryDirectory() as folder:
            stats_path = Path(folder) / "stats.json"
            for scene in scenes:
                for technique in args.techniques.split(","):
                    for size in (int(s) for s in args.sizes.split(",")):
                        record = measure_cell(scene, technique, size, args.probes, args.slow_ms, stats_path)
                        print(f"{scene.stem} {technique} {size}: {record.get('error', 'measured')}", file=sys.stderr)
                        records.append(record)
                        if args.jsonl:
                            with open(args.jsonl, "a") as out:
                                out.write(json.dumps(record) + "\n")
    text = tables(records)
    print(text, end="")
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
