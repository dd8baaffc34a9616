#!/usr/bin/env bash
# The source folders' layers (README "Layout"): a folder includes only its own headers and those of
# lower layers, so no two folders include each other. Exit 1 naming each include that breaks it.
set -euo pipefail
cd "$(dirname "$0")/.."
declare -A rank=(
    [sombra]=0 [shared]=0                # include/sombra (the API), cl/shared (host/kernel structs)
    [host]=1 [scene]=1                   # OpenCL runtime; scene files and readers
    [memory]=2 [geometry]=2              # DSM storage backends; rasterizer, fragments, BVH, packing
    [shadows]=3 [clustering]=3           # DSM generation, summed-area tables, reference; object clusters
    [distributed]=3                      # regions of a distributed render, the maps its ranks exchange
    [techniques]=4                       # shadow techniques as modules
    [render]=5                           # the orchestrator
    [view]=6                             # the viewer's session and HTTP server
    [cli]=7                              # the command line
)
status=0
for dir in src/*/; do
    folder=$(basename "$dir")
    [[ -n "${rank[$folder]:-}" ]] || { echo "check-layers: src/$folder has no layer (add it to scripts/check-layers.sh and README Layout)"; status=1; continue; }
    while IFS=: read -r file line text; do
        target=$(sed -E 's/.*#include "([a-z_]+)\/.*/\1/' <<<"$text")
        [[ "$target" == "$folder" ]] && continue
        if [[ -z "${rank[$target]:-}" || ${rank[$target]} -ge ${rank[$folder]} ]]; then
            echo "check-layers: $file:$line includes $target/ (layer ${rank[$target]:-?}) from $folder/ (layer ${rank[$folder]})"
            status=1
        fi
    done < <(grep -nH -E '^#include "[a-z_]+/' "$dir"*.h "$dir"*.cpp 2>/dev/null || true)
done
[[ $status == 0 ]] && echo "check-layers: every include goes to a lower layer"
exit $status
