#!/usr/bin/env bash
# The suite on Intel's OpenCL CPU runtime as the only platform (issue 33): installs it if missing
# (scripts/intel-opencl.sh: PyPI, 276 MB once), then runs on it the tests that compare the kernels
# with CPU references and closed forms (ctest names matching "reference|accuracy|against", not the
# package tests: 44 tests). `--all` runs the whole suite instead, then compares every shipped scene
# × technique on Intel with PoCL (tests/portability/intel.sh --all-scenes). Uses the build in
# build/ (scripts/build.sh first). The library tests take the suite's device (SOMBRA_DEVICE=cpu:
# Intel's device is a CPU), the CLI tests the CLI's default (auto: the only device). Intel compiles
# each program in seconds and caches nothing: the program cache (~/.cache/sombra/kernels) makes a
# second run much quicker.
#
#   scripts/intel-check.sh [--all] [-j N]
#
# Exit: 0 when everything passed, 1 otherwise; 77 when Intel's runtime cannot be installed.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/local/bin:/usr/bin:/bin:${PATH:-}"
subset=(-R "reference|accuracy|against" -LE package) jobs=2 all=0
while [ $# -gt 0 ]; do
  case $1 in
    --all) subset=() all=1; shift ;;
    -j) jobs=$2; shift 2 ;;
    *) echo "intel-check: unknown argument $1 (--all, -j N)" >&2; exit 2 ;;
  esac
done
[ -x build/sombra ] || { echo "intel-check: no build/sombra: run scripts/build.sh first" >&2; exit 2; }
env=$(scripts/intel-opencl.sh --env)
eval "$env"
build/sombra devices
build/sombra devices | grep -q "Intel(R) OpenCL" || { echo "intel-check: Intel's device is not listed" >&2; exit 1; }
start=$(date +%s)
status=0
SOMBRA_DEVICE=cpu ctest --test-dir build --output-on-failure -j"$jobs" --timeout 900 "${subset[@]}" || status=1
echo "intel-check: $([ $all = 1 ] && echo 'the whole suite' || echo "ctest ${subset[*]}") on Intel's runtime: $([ $status = 0 ] && echo passed || echo FAILED) in $(( $(date +%s) - start )) s"
if [ $all = 1 ]; then
  start=$(date +%s)
  tests/portability/intel.sh build/sombra build/python build/tests/intel --all-scenes || status=1
  echo "intel-check: every scene × technique, Intel against PoCL: $([ $status = 0 ] && echo passed || echo FAILED) in $(( $(date +%s) - start )) s"
fi
exit $status
