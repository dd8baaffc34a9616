#!/usr/bin/env bash
# CI's sanitizer step: the ASan + UBSan build (scripts/configure-sanitize.sh) of the library, the
# CLI and the reader, scene and CLI tests; runs those tests and the fuzz-regression replays, then
# every fuzz harness for SECONDS (default 20). Exit 1 on any failure or finding.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
start=$(date +%s)
scripts/configure-sanitize.sh
cmake --build build-sanitize -j"$(nproc)"
# OpenCL (PoCL, LLVM) is not ours and keeps memory until exit: leaks are checked by the fuzzers only
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd build-sanitize && ctest --output-on-failure -j"$(nproc)" --timeout 600)
unset ASAN_OPTIONS
scripts/fuzz.sh "$seconds"
echo "sanitize: done in $(( $(date +%s) - start )) s"
