#!/usr/bin/env bash
# Ament Table 1 analogue over data sets and light set-ups: the real CT (256×128×128) and MRI
# (181×217×181), each with 3 orthodirectional and 2 point lights, plus the CT with its own lights and
# the filter-width sweep; then procedural clouds of 256³ and 512³ voxels (bench/scenes/) with their
# own point + directional light. TF change and light move are the granular first pass of Ament
# Alg. 1 (one light moved: its table and cache entries). Writes bench/results/lowpass_table_<tag>.
# {md,csv} and, when python3 has matplotlib (bench/requirements.txt), lowpass_table_<tag>.png.
# Usage: bench/run_lowpass_tables.sh [OUT] [SETS]   SETS: any of ct mri cloud256 cloud512 (default all)
set -euo pipefail
cd "$(dirname "$0")/.."
bench=./build/bench/sombra_bench_lowpass
out=${1:-bench/results}
sets=${2:-ct mri cloud256 cloud512}
run() {  # TAG ARGS…
    local tag=$1
    shift
    "$bench" --out "$out" --tag "$tag" "$@"
    if python3 -c "import matplotlib" 2>/dev/null; then
        python3 bench/plot_lowpass.py "$out/lowpass_table_$tag.csv" "$out/lowpass_table_$tag.png"
    else
        echo "note: no plot for $tag (python3 with matplotlib: bench/requirements.txt)"
    fi
}
for set in $sets; do
    case $set in
    ct)
        run ct_scene --runs 2 --widths 1,3,7,11,15
        for lights in ortho3 point2; do
            run "ct_$lights" --lights "$lights" --runs 2 --widths 7 --points 500
        done ;;
    mri)
        for lights in ortho3 point2; do
            run "mri_$lights" --scene data/scenes/mri_head.json --lights "$lights" --runs 2 --widths 7 --points 500
        done ;;
    cloud256)  # 256² image; tables capped at the default 2^24 entries (cells coarser than a voxel)
        run cloud256 --scene bench/scenes/cloud_256.json --runs 3 --widths 1,7,15 --points 500 ;;
    cloud512)  # 128² image, 2 runs, one width: minutes, not hours, on 2 shared cores; tables 2^24
               # entries (the cap makes the cells 2–3 voxels wide)
        run cloud512 --scene bench/scenes/cloud_512.json --width 128 --height 128 --runs 2 --widths 7 --points 300 ;;
    *) echo "run_lowpass_tables.sh: unknown set '$set' (ct mri cloud256 cloud512)" >&2; exit 2 ;;
    esac
done
