#!/usr/bin/env bash
# Second command of the README: builds and runs the whole test suite on PoCL (or any device).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
scripts/check-deps.sh    # fails when the build used a package the install script does not list
cd build
# no shadow-cache history across runs (docs/shadows.md "Auto across processes"): what one run of the
# suite measured must not change what the next one tests (the C++ and Python suites set it too)
export SOMBRA_AUTO_HISTORY="${SOMBRA_AUTO_HISTORY:-off}"
ctest --output-on-failure -j"$(nproc)" --timeout 600
