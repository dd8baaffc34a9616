#!/usr/bin/env bash
# Ament Table 1 analogue over data sets and light set-ups: the real CT (256×128×128) and MRI
# (181×217×181), each with 3 orthodirectional and 2 point lights, plus the CT with its own lights and
# the filter-width sweep; then procedural clouds of 256³ and 512³ voxels (bench/scenes/) with their
# own point + directional light. TF change and light move are the granular first pass of Ament
# Alg. 1 (one light moved: its table and cache entries). Writes bench/results/lowpass_table_<tag>.{md,csv}.
# Usage: bench/run_lowpass_tables.sh [OUT] [SETS]   SETS: any of ct mri cloud256 cloud512 (default all)
set -euo pipefail
cd "$(dirname "$0")/.."
bench=./build/bench/sombra_bench_lowpass
out=${1:-bench/results}
sets=${2:-ct mri cloud256 cloud512}
for set in $sets; do
    case $set in
    ct)
        "$bench" --out "$out" --tag ct_scene --runs 3 --widths 1,3,7,11,15
        for lights in ortho3 point2; do
            "$bench" --lights "$lights" --out "$out" --tag "ct_$lights" --runs 3 --widths 7 --points 500
        done ;;
    mri)
        for lights in ortho3 point2; do
            "$bench" --scene data/scenes/mri_head.json --lights "$lights" --out "$out" --tag "mri_$lights" --runs 3 --widths 7 --points 500
        done ;;
    cloud256)  # 256² image; tables at the default 2^24 entries (cells of ~1.3 voxels)
        "$bench" --scene bench/scenes/cloud_256.json --out "$out" --tag cloud256 --runs 3 --widths 1,7,15 --points 500 ;;
    cloud512)  # 128² image to stay within minutes on 2 cores; tables 2^24 entries (cells of ~2.6 voxels)
        "$bench" --scene bench/scenes/cloud_512.json --width 128 --height 128 --out "$out" --tag cloud512 --runs 3 --widths 1,7,15 --points 300 ;;
    *) echo "run_lowpass_tables.sh: unknown set '$set' (ct mri cloud256 cloud512)" >&2; exit 2 ;;
    esac
done
