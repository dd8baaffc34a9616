#!/usr/bin/env bash
# First command of the README: installs what is needed, builds, renders the default scene with
# deep shadow maps.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
mkdir -p out
./build/sombra render data/scenes/default.json -o out/default.png --shadows dsm --stats out/default-stats.json
echo "setup: rendered out/default.png (stats in out/default-stats.json)"
