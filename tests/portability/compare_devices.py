#!/usr/bin/env python3
"""Renders the shipped scenes with each technique on two OpenCL devices and compares the images.

    compare_devices.py DEVICE REFERENCE [--size N] [--scenes A B …] [--techniques T …]
                       [--max-abs X] [--mean-abs Y]

DEVICE and REFERENCE: a --device value (auto, cpu, gpu, an index) or a part of a platform's name
("Intel", "Portable Computing Language"). Prints one line per scene and technique (max and mean
|Δ| over RGBA) and the totals. A render both devices refuse (a technique that does not take the
scene) is listed as refused; one device alone refusing is a failure. Exit 1 on a failure, on a
non-finite value, or when the largest max |Δ| exceeds --max-abs or the mean over every render
exceeds --mean-abs (no bounds: only reported). Needs the Python module on PYTHONPATH (build/python).
Used by tests/portability/intel.sh (Intel against PoCL) and scripts/gpu-check.sh (a GPU against PoCL).
"""
import argparse
import concurrent.futures
import glob
import os
import sys
import time

import numpy as np
import sombra

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TECHNIQUES = ["none", "rays", "dsm", "shadowmap", "lowpass", "ao", "cone"]


def context(selector):
    """A Context for a --device value or for the first device of the platform whose name holds it."""
    if selector in ("auto", "cpu", "gpu") or selector.isdigit():
        return sombra.Context(selector)
    for device in sombra.list_devices():
        if selector in device["platform"]:
            return sombra.Context(str(device["index"]))
    names = ", ".join(f"{d['index']}: {d['platform']} / {d['name']}" for d in sombra.list_devices()) or "none"
    sys.exit(f"compare_devices.py: no platform named like '{selector}'; devices: {names}")


def render(ctx, scene, options):
    """(image, seconds), or (the refusal's message, seconds)."""
    started = time.time()
    try:
        return sombra.render(ctx, scene, **options)[0], time.time() - started
    except sombra.Error as error:
        return str(error), time.time() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("device")
    parser.add_argument("reference")
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--scenes", nargs="+", help="names in data/scenes (default: all)")
    parser.add_argument("--techniques", nargs="+", default=TECHNIQUES)
    parser.add_argument("--max-abs", type=float)
    parser.add_argument("--mean-abs", type=float)
    args = parser.parse_args()
    scenes = args.scenes or sorted(os.path.basename(p)[:-5] for p in glob.glob(f"{SOURCE}/data/scenes/*.json"))
    on, reference = context(args.device), context(args.reference)
    print(f"device: {on.device}; reference: {reference.device}; {args.size}², deep and binary maps 128²")
    print(f"{'scene':<18} {'technique':<13} {'max |Δ|':>9} {'mean |Δ|':>10} {'seconds':>13}")
    worst, means, failures, started = 0.0, [], [], time.time()
    # the two devices render at once (the module releases the GIL): compiling the programs, which
    # takes most of a cold run, is single-threaded in both drivers
    pool = concurrent.futures.ThreadPoolExecutor(2)
    for name in scenes:
        scene = sombra.load_scene(f"{SOURCE}/data/scenes/{name}.json")
        # the shadow cache off and on, never auto: auto measures each device's times, and the two
        # devices (rendering at once) then chose differently (the default scene's rays, 0.055 max |Δ|)
        for technique, cache in [(t, c) for t in args.techniques for c in (("off",) if t == "none" else ("off", "on"))]:
            options = dict(shadows=technique, width=args.size, height=args.size, shadow_cache=cache)
            if technique in ("dsm", "shadowmap"):
                options["dsm_resolution"] = 128
            label = technique if technique == "none" else f"{technique}/{cache}"
            (a, seconds_a), (b, seconds_b) = pool.map(lambda ctx: render(ctx, scene, options), (on, reference))
            if isinstance(a, str) or isinstance(b, str):
                both = isinstance(a, str) and isinstance(b, str)
                print(f"{name:<18} {label:<13} refused{'' if both else ' on one device only'}: {a if isinstance(a, str) else b}")
                if not both:
                    failures.append(f"{name} {label}: refused on one device only")
                continue
            if not (np.isfinite(a).all() and np.isfinite(b).all()):
                failures.append(f"{name} {label}: non-finite values")
            d = np.abs(a.astype(np.float64) - b)
            worst = max(worst, float(d.max()))
            means.append(float(d.mean()))
            print(f"{name:<18} {label:<13} {d.max():9.2e} {d.mean():10.2e} {seconds_a:6.1f} {seconds_b:6.1f}"
                  + ("   <- differs" if d.max() > 0.02 else ""), flush=True)
    mean = float(np.mean(means)) if means else 0.0
    print(f"{len(means)} renders on each device in {time.time() - started:.0f} s: largest max |Δ| {worst:.3g}, mean |Δ| {mean:.3g}")
    if args.max_abs is not None and worst > args.max_abs:
        failures.append(f"largest max |Δ| {worst:.3g} > {args.max_abs:g}")
    if args.mean_abs is not None and mean > args.mean_abs:
        failures.append(f"mean |Δ| {mean:.3g} > {args.mean_abs:g}")
    for failure in failures:
        print(f"FAIL {failure}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
