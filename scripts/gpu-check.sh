#!/usr/bin/env bash
# The GPU check (issue 33 item 4): one command for the day a machine with a GPU is lent. Builds,
# lists the OpenCL devices, runs the library and Python tests on the device, renders the shipped
# scenes with every technique on the device and on PoCL and compares the images, and runs the
# camera-pass and DSM benches; everything goes into one report file. On an H200 it took 73–219 s
# (each step has its own time limit; docs/gpu-check.md). CI runs it with
# `--device cpu --quick --no-build` on PoCL so that it cannot rot.
#
#   scripts/gpu-check.sh [--device gpu|cpu|N] [--quick] [--no-build] [--report FILE]
#                        [--images-to DIR] [--tests-limit SECONDS] [--step-limit SECONDS]
#
# --images-to DIR: render the scenes with the CLI into DIR (scripts/gpu-images.sh) instead of
# comparing with PoCL in one process, for a machine without PoCL or this build's Python (the lent
# machine: scripts/gpu-remote.sh runs it there from a bundle, scripts/gpu-bundle.sh makes the
# bundle here); build/tests/sombra_compare_images then compares DIR with PoCL's renders here.
#
# Exit 0 when every step ran to its end (image differences are reported, not judged: one GPU
# measured, with the shadow cache's auto in its renders, sets no tolerance yet), 1 otherwise.
set -uo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/local/bin:/usr/bin:/bin:${PATH:-}"
device=gpu quick=0 build=1 report=gpu-check.md images_to="" tests_limit=300 step_limit=""
while [ $# -gt 0 ]; do
  case $1 in
    --device) device=$2; shift 2 ;;
    --quick) quick=1; shift ;;
    --no-build) build=0; shift ;;
    --report) report=$2; shift 2 ;;
    --images-to) images_to=$2; shift 2 ;;
    --tests-limit) tests_limit=$2; shift 2 ;;
    --step-limit) step_limit=$2; shift 2 ;;  # caps every other step's limit (a lease's minutes)
    *) echo "gpu-check: unknown argument $1 (--device D, --quick, --no-build, --report FILE, --images-to DIR, --tests-limit S, --step-limit S)" >&2; exit 2 ;;
  esac
done
start=$(date +%s)
failed=0
{
  echo "# sombra GPU check"
  echo
  echo "$(date -u '+%Y-%m-%d %H:%M UTC'), commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'), device '$device'$([ $quick = 1 ] && echo ', quick')"
} >"$report"
: >"${report%.md}.log"  # every step's whole output (the report keeps the last 60 lines of each)

# step NAME SECONDS COMMAND…: runs it with a time limit, its output's last 60 lines into the report
step() {
  local name=$1 limit=$2
  shift 2
  [ -n "$step_limit" ] && [ "$name" = "${name#tests on}" ] && [ "$limit" -gt "$step_limit" ] && limit=$step_limit
  local t0 out status
  t0=$(date +%s)
  out=$(timeout "$limit" "$@" 2>&1)
  status=$?
  {
    echo
    echo "## $name ($(( $(date +%s) - t0 )) s, exit $status)"
    echo
    echo '```'
    tail -n 60 <<<"$out"
    echo '```'
  } >>"$report"
  printf '== %s (exit %d)\n%s\n' "$name" "$status" "$out" >>"${report%.md}.log"
  [ $status -eq 0 ] || failed=1
  echo "gpu-check: $name: exit $status"
}

[ $build = 1 ] && step "build" 360 scripts/build.sh
step "devices" 60 build/sombra devices
if [ $quick = 1 ]; then
  step "tests on $device (accuracy subset)" 300 env SOMBRA_DEVICE="$device" ctest --test-dir build -j2 --timeout 120 -R "accuracy"
else
  # the whole suite but what is not about the device (packages, fuzz replays, the second OpenCL
  # implementation, the layout check); the CLI tests use the CLI's default device, auto: the GPU.
  # Where this build's Python module does not import (another Python), its tests are left out too.
  skip="portability|fuzz-regressions|layout"
  PYTHONPATH=build/python python3 -c "import sombra" 2>/dev/null || skip="$skip|python|view:|numpy|pytest|distributed"
  jobs=$(( $(nproc) > 4 ? $(nproc) : 4 ))
  if command -v ctest >/dev/null; then
    step "tests on $device" "$tests_limit" env SOMBRA_DEVICE="$device" ctest --test-dir build -j"$jobs" --timeout 300 --output-on-failure \
      -LE "package|slow|bench" -E "$skip"
  else  # no CMake there: the Catch2 binary alone, in as many shards as processes
    step "tests on $device (sombra_tests in $jobs shards; no ctest)" "$tests_limit" env SOMBRA_DEVICE="$device" bash -c \
      "seq 0 $(( jobs - 1 )) | xargs -P $jobs -I{} build/tests/sombra_tests --shard-count $jobs --shard-index {} --reporter compact"
  fi
fi

# images: every shipped scene and technique on the device and on PoCL, side by side
size=$([ $quick = 1 ] && echo 24 || echo 64)
scenes=$([ $quick = 1 ] && echo "default smoke" || ls data/scenes/*.json | xargs -n1 basename | sed 's/\.json$//' | tr '\n' ' ')
techniques=$([ $quick = 1 ] && echo "none dsm rays" || echo "none dsm rays shadowmap lowpass ao cone")
if [ -n "$images_to" ]; then
  step "images on $device into $images_to ($size², $techniques)" 240 scripts/gpu-images.sh "$device" "$images_to" --size "$size" \
    --scenes "$scenes" --techniques "$techniques" --jobs "$(( $(nproc) > 8 ? 8 : 2 ))"
else
  # shellcheck disable=SC2086  # the scene and technique lists are words without spaces
  step "images: $device against PoCL ($size², $techniques)" 240 env PYTHONPATH=build/python /usr/bin/python3 \
    tests/portability/compare_devices.py "$device" "Portable Computing Language" --size "$size" --scenes $scenes --techniques $techniques
fi
if [ $quick = 1 ]; then
  step "camera bench" 120 build/bench/sombra_bench_camera --scene data/scenes/default.json --device "$device" --width 64 --height 64 --runs 1 --no-scalar
  step "DSM bench" 120 build/bench/sombra_bench_dsm --scene data/scenes/default.json --device "$device" --resolutions 64 --eps 0.02 --width 32 --height 32 --runs 1 --points 20
else
  step "camera bench" 180 build/bench/sombra_bench_camera --scene data/scenes/default.json --device "$device" --width 512 --height 512 --runs 3 --no-scalar
  step "DSM bench" 180 build/bench/sombra_bench_dsm --scene data/scenes/default.json --device "$device" --resolutions 256,512 --eps 0.01 --runs 3
fi
echo >>"$report"
echo "Total: $(( $(date +%s) - start )) s; $([ $failed = 0 ] && echo 'every step ran to its end' || echo 'a step failed: see its exit status')." >>"$report"
echo "gpu-check: report in $report ($(( $(date +%s) - start )) s)"
exit $failed
