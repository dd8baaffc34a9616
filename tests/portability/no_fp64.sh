#!/usr/bin/env bash
# Devices without cl_khr_fp64 (many GPUs) must build every program: the low-pass family's lookups
# have a float path (cl/lowpass.h, --sat-precision float, chosen by auto on such devices). This
# collects the programs tiny renders of every technique build with float lookups
# (SOMBRA_DUMP_PROGRAMS, also those loaded from the program cache) and compiles each with clang's OpenCL front end
# with cl_khr_fp64 removed: any `double` in a program is an error there. A check of the check:
# the same low-pass program with double lookups must fail. Usage: no_fp64.sh SOMBRA_CLI WORK_DIR.
# Exit 77 (skipped) without clang.
set -euo pipefail
cli=$1 work=$2
clang=$(command -v clang-15 || command -v clang || true)
[ -n "$clang" ] || { echo "no_fp64.sh: clang is not installed: skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
cat >"$work/tiny.json" <<'JSON'
{"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "image": {"width": 8, "height": 8},
 "volumes": [{"generator": {"type": "sphere", "size": 8}, "transform": {"scale": 0.1},
              "transfer_function": {"rgb_points": [0, 1, 1, 1, 1, 1, 0.5, 0.2], "opacity_points": [0, 0, 1, 0.5]}}],
 "lights": [{"type": "directional", "direction": [0, -1, -1]}, {"type": "point", "position": [0.3, 0.4, 0.5]}]}
JSON
# compile DIR: every dumped program with fp64 removed; prints the failures, returns their count
compile() {
    local failed=0
    for source in "$1"/*.cl; do
        options=$(sed 's/-cl-kernel-arg-info//' "${source%.cl}.options")
        # shellcheck disable=SC2086
        if ! "$clang" -x cl $options -Xclang -finclude-default-header -Xclang -cl-ext=-cl_khr_fp64 -fsyntax-only \
            "$source" >"${source%.cl}.log" 2>&1; then
            failed=$((failed + 1))
            [ "${2:-}" = quiet ] || { echo "FAIL $(basename "$source"): $options"; grep error "${source%.cl}.log" | head -5; }
        fi
    done
    return $failed
}
render() {  # DUMP_DIR ARGS…
    local dump=$1; shift
    SOMBRA_DUMP_PROGRAMS="$dump" "$cli" render "$work/tiny.json" -o "$work/out.png" -q "$@"
}
render "$work/float" --shadows none
for cache in on off; do
    for technique in dsm shadowmap; do render "$work/float" --shadows $technique --dsm-res 16 --shadow-cache $cache; done
    render "$work/float" --shadows rays --shadow-cache $cache
    for technique in lowpass ao cone; do render "$work/float" --shadows $technique --sat-precision float --shadow-cache $cache; done
done
render "$work/float" --shadows lowpass --filter-kernel gauss --sat-precision float --shadow-cache off
render "$work/float" --shadows lowpass --filter-kernel gauss --sat-precision float --shadow-cache on
programs=$(ls "$work/float"/*.cl | wc -l)
status=0
compile "$work/float" || status=1
render "$work/double" --shadows lowpass --sat-precision double --shadow-cache off
if compile "$work/double" quiet; then
    echo "no_fp64.sh: the double low-pass program compiled without fp64: the check checks nothing"
    status=1
fi
[ $status = 0 ] && echo "no_fp64.sh: $programs programs compile without cl_khr_fp64"
exit $status
