#!/usr/bin/env bash
# Configures build-sanitize/: clang, AddressSanitizer + UndefinedBehaviorSanitizer (every report
# fatal), coverage for libFuzzer, the libFuzzer harnesses (fuzz/) and the reader, scene and CLI
# tests. Used by scripts/fuzz.sh and scripts/sanitize.sh. A unity build (CMAKE_UNITY_BUILD: the sources
# of a target compiled a batch at a time): 3.3–4 min instead of ≈ 12 on 2 cores; scripts/build.sh
# compiles each file alone, so a file that misses an include still fails there.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/local/bin:/usr/bin:/bin:${PATH:-}"
flags="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -gline-tables-only"
flags="$flags -fsanitize=fuzzer-no-link"   # coverage feedback from the library, not only the harness
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
      -DCMAKE_C_FLAGS="$flags" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1" \
      -DSOMBRA_FUZZ=ON -DSOMBRA_BUILD_BENCH=OFF -DCMAKE_UNITY_BUILD=ON \
      -DSOMBRA_TEST_ONLY="test_volume_io|test_volume_io_libs|test_mesh|test_cli|test_hostile_input" >/dev/null
