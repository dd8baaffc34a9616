#!/usr/bin/env bash
# Configures and builds sombra (Release) into build/.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/local/bin:/usr/bin:/bin:${PATH:-}"   # PoCL needs `ld` on PATH
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
