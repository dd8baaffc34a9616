#!/usr/bin/env bash
# Rules for the kernel sources (cl/), each a grep that names every line breaking it (exit 1):
#   static-inline  every helper function is `static inline` (or a macro that says so): a plain
#                  `inline` has C99 semantics in OpenCL C, an inline definition only, and where a
#                  compiler does not inline the call it is left as an external symbol nobody defines
#                  (NVIDIA's ptxas: "Unresolved extern function").
#   vector-lanes   no vector is written one component at a time through a pointer cast
#                  (`((double*)&v)[a] =`): its other lanes keep whatever the stack held, and a
#                  3-component vector has a fourth, padding lane that vector arithmetic carries
#                  along. A subnormal left there by an earlier kernel made PoCL's cone pass 1.4–1.7×
#                  slower for the rest of a process (cl/lowpass.h sat_cone_depth; bench/README.md
#                  "sombra_bench_frame_sequence"). Set the whole vector instead.
set -euo pipefail
case "${1:-}" in
static-inline)
    pattern='^\s*inline\b|#define\s+\w+\s+inline\s*$'
    broken="plain inline in kernel sources (use static inline)"
    kept="every kernel helper is static inline" ;;
vector-lanes)
    pattern='\(\(\s*(const\s+)?\w+\s*\*\s*\)\s*&\s*\w+\s*\)\s*\[[^]]*\]\s*=[^=]'
    broken="a vector written lane by lane through a pointer cast (set the whole vector)"
    kept="no vector is written lane by lane through a pointer cast" ;;
*)
    echo "usage: kernel_rules.sh static-inline|vector-lanes" >&2
    exit 2 ;;
esac
cd "$(dirname "$0")/../../cl"
found=$(grep -rnE "$pattern" --include='*.h' --include='*.cl' . || true)
if [ -n "$found" ]; then
    echo "kernel_rules.sh $1: $broken:"
    echo "$found"
    exit 1
fi
echo "kernel_rules.sh $1: $kept"
