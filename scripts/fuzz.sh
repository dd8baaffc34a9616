#!/usr/bin/env bash
# Builds the libFuzzer harnesses (ASan + UBSan, build-sanitize/) and runs each for SECONDS (default
# 60), starting from fuzz/corpus/NAME and what earlier runs added (build-sanitize/fuzz-corpus/NAME).
#   scripts/fuzz.sh [SECONDS] [NAME…]      e.g. scripts/fuzz.sh 600 mesh_ply scene
# A finding (crash, sanitizer report, uncaught exception, hang > 10 s, malloc > 1 GiB) is written
# to build-sanitize/fuzz-findings/NAME/; after the fix, copy it into tests/fuzz-regressions/NAME/,
# where ctest replays it on every build. Prints executions per second per harness; exit 1 on a finding.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(nifti nifti_gz npy npz den inr vtk raw mesh_ply mesh_obj scene points nrrd metaimage tiff vdb dicom deep_exr cli view_request)
# Harnesses that run ITK's readers: ITK 5.2 leaks on its own error paths (NrrdIO's gzip reader,
# TIFFImageIO's strip buffer: a few hundred bytes per refused file, found in the first seconds), so
# for them leaks are not findings; crashes, sanitizer reports, hangs and big allocations still are.
# OpenVDB 10 leaks the node it was reading when a chunk fails to decompress (RootNode::readTopology).
library_leaks=" nrrd metaimage tiff dicom vdb "

scripts/configure-sanitize.sh
cmake --build build-sanitize -j"$(nproc)" --target "${names[@]/#/fuzz_}"

export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
findings=0 total=0
printf '%-10s %10s %12s %s\n' harness "execs/s" executions result
for name in "${names[@]}"; do
  corpus=build-sanitize/fuzz-corpus/$name artifacts=build-sanitize/fuzz-findings/$name
  mkdir -p "$corpus" "$artifacts"
  log=build-sanitize/fuzz-$name.log
  status=0
  options=$ASAN_OPTIONS
  # ITK's readers run with fd 2 captured (library chatter, volume_io_itk.cpp): reports go to a file
  [[ $library_leaks == *" $name "* ]] &&
    options="${ASAN_OPTIONS//detect_leaks=1/detect_leaks=0}:log_path=$PWD/build-sanitize/fuzz-$name.asan"
  # -jobs/-workers 1: CI has 2 cores; one harness at a time keeps the numbers comparable
  # the CLI prints help and error lines at every run: its stdout and stderr are closed (libFuzzer
  # keeps its own report stream)
  quiet=""
  [ "$name" = cli ] && quiet=-close_fd_mask=3
  # -timeout: an input that runs 30 s is a hang; a mutated .vdb read whole under ASan at -O1 took
  # 7 s (2026-12-03), too close to the former 10 s on a slower CI machine

  ASAN_OPTIONS=$options build-sanitize/fuzz/fuzz_"$name" "$corpus" fuzz/corpus/"$name" -max_total_time="$seconds" -timeout=30 $quiet \
    -malloc_limit_mb=1024 -rss_limit_mb=2560 -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1 || status=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  result=ok
  if [ $status -ne 0 ]; then
    result="FINDING (see $log and build-sanitize/fuzz-$name.asan.*, inputs in $artifacts/)"
    findings=$((findings + 1))
  fi
  total=$((total + ${runs:-0}))
  printf '%-10s %10s %12s %s\n' "$name" "${rate:-?}" "${runs:-?}" "$result"
done
echo "fuzz: $total executions in all, $findings harness(es) with findings"
[ $findings -eq 0 ]
