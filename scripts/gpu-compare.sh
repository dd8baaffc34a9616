#!/usr/bin/env bash
# The second half of the GPU check (issue 33), here: the images a lent machine rendered
# (scripts/gpu-remote.sh brings them back as images.tar.gz) against the same renders on PoCL.
#
#   scripts/gpu-compare.sh IMAGES.tar.gz|DIR [--size N] [--out DIR]
#
# Renders every file the device rendered, on PoCL (scripts/gpu-images.sh, same size and options),
# then build/tests/sombra_compare_images prints max and mean |Δ| per image and writes side-by-side
# PNGs (device | PoCL | 10 × |Δ|) into OUT/side-by-side. Exit 1 when a render is missing on one side.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { echo "usage: scripts/gpu-compare.sh IMAGES.tar.gz|DIR [--size N] [--out DIR]" >&2; exit 2; }
input=$1
shift
size=64 out=build/gpu-compare
while [ $# -gt 0 ]; do
  case $1 in
    --size) size=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) echo "gpu-compare: unknown argument $1" >&2; exit 2 ;;
  esac
done
rm -rf "$out" && mkdir -p "$out/device"
if [ -d "$input" ]; then cp "$input"/* "$out/device/"; else tar -xzf "$input" -C "$out/device"; fi
# the scenes and techniques the device was asked for: every line of its renders.txt
scenes=$(awk '{ print $1 }' "$out/device/renders.txt" | sort -u | tr '\n' ' ')
techniques=$(awk '{ print $2 }' "$out/device/renders.txt" | sort -u | tr '\n' ' ')
scripts/gpu-images.sh cpu "$out/pocl" --size "$size" --scenes "$scenes" --techniques "$techniques" --jobs 2 >/dev/null
build/tests/sombra_compare_images "$out/device" "$out/pocl" --side-by-side "$out/side-by-side"
