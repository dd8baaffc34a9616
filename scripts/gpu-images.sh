#!/usr/bin/env bash
# Renders the shipped scenes with each technique into a folder of EXR files with the CLI, on one
# device (issue 33, the GPU check): scripts/gpu-check.sh runs it on the lent machine (no PoCL, no
# Python module for its Python there), and here on PoCL into another folder; then
# build/tests/sombra_compare_images compares the two folders file by file.
#
#   scripts/gpu-images.sh DEVICE DIR [--size N] [--scenes "A B"] [--techniques "T …"] [--jobs J]
#
# DIR/SCENE_TECHNIQUE.exr per render; DIR/renders.txt: one line per render with its seconds, or the
# refusal (a technique the scene does not take is refused on every device, and then it has no
# file on either side). Exit 1 when a render fails for another reason (a crash, a timeout).
set -uo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: scripts/gpu-images.sh DEVICE DIR [--size N] [--scenes \"A B\"] [--techniques \"T …\"] [--jobs J]" >&2; exit 2; }
device=$1 dir=$2
shift 2
size=64 jobs=4
scenes=$(ls data/scenes/*.json | xargs -n1 basename | sed 's/\.json$//' | tr '\n' ' ')
techniques="none dsm rays shadowmap lowpass ao cone"
while [ $# -gt 0 ]; do
  case $1 in
    --size) size=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --techniques) techniques=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    *) echo "gpu-images: unknown argument $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$dir"
cli=${SOMBRA_CLI:-build/sombra}
export device dir size cli
# one render: deep and binary maps at 128² (as compare_devices.py), no shadow cache (auto decides
# from measured costs, which differ between devices); a refusal ("… does not take …")
# is recorded, any other failure (crash, timeout) is a failure of the check
render_one() {
  local scene=$1 technique=$2 t0 out status extra=""
  [ "$technique" = dsm ] || [ "$technique" = shadowmap ] && extra="--dsm-res 128"
  t0=$(date +%s.%N)
  # shellcheck disable=SC2086  # extra is empty or two words
  out=$(timeout 120 "$cli" render "data/scenes/$scene.json" --device "$device" --shadows "$technique" $extra --shadow-cache off \
        --width "$size" --height "$size" -o "$dir/${scene}_$technique.exr" -q 2>&1)
  status=$?
  local seconds
  seconds=$(awk "BEGIN { print $(date +%s.%N) - $t0 }")
  if [ $status -eq 0 ]; then
    printf '%-18s %-10s %6.1f s\n' "$scene" "$technique" "$seconds"
  elif [ $status -eq 124 ] || [ $status -ge 128 ]; then
    printf '%-18s %-10s FAILED (exit %d): %s\n' "$scene" "$technique" "$status" "$(echo "$out" | tail -n 1)"
  else
    printf '%-18s %-10s refused: %s\n' "$scene" "$technique" "$(echo "$out" | tail -n 1)"
  fi
}
export -f render_one
for scene in $scenes; do for technique in $techniques; do echo "$scene $technique"; done; done |
  xargs -P "$jobs" -L 1 bash -c 'render_one "$0" "$1"' | sort >"$dir/renders.txt"
cat "$dir/renders.txt"
! grep -q FAILED "$dir/renders.txt"
