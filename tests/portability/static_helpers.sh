#!/usr/bin/env bash
# Every helper function in the kernel sources is `static inline` (or a macro that says so): a plain
# `inline` has C99 semantics in OpenCL C, an inline definition only, and where a compiler does not
# inline the call it is left as an external symbol nobody defines (NVIDIA's ptxas: "Unresolved
# extern function"). Exit 1 naming each plain `inline`.
set -euo pipefail
cd "$(dirname "$0")/../../cl"
found=$(grep -rnE '^\s*inline\b|#define\s+\w+\s+inline\s*$' --include='*.h' --include='*.cl' . || true)
if [ -n "$found" ]; then
    echo "static_helpers.sh: plain inline in kernel sources (use static inline):"
    echo "$found"
    exit 1
fi
echo "static_helpers.sh: every kernel helper is static inline"
