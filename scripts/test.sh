#!/usr/bin/env bash
# Second command of the README: builds and runs the whole test suite on PoCL (or any device).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
scripts/check-deps.sh    # fails when the build used a package the install script does not list
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 600
