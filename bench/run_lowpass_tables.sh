#!/usr/bin/env bash
# Ament Table 1 analogue over data sets and light set-ups: the real CT (256×128×128) and MRI
# (181×217×181, 256³-class), each with 3 orthodirectional and 2 point lights, plus the CT with its
# own lights and the filter-width sweep. Writes bench/results/lowpass_table_<tag>.{md,csv}.
set -euo pipefail
cd "$(dirname "$0")/.."
bench=./build/bench/sombra_bench_lowpass
out=${1:-bench/results}
"$bench" --out "$out" --tag ct_scene --runs 2 --widths 1,3,7,11,15
for scene in ct:data/scenes/default.json mri:data/scenes/mri_head.json; do
    for lights in ortho3 point2; do
        "$bench" --scene "${scene#*:}" --lights "$lights" --out "$out" --tag "${scene%%:*}_$lights" --runs 2 --widths 7 --points 500
    done
done
