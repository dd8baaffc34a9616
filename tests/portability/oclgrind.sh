#!/usr/bin/env bash
# sombra on a second OpenCL implementation: Oclgrind 21.10, a simulated OpenCL 1.2 GPU device
# that checks every memory access and, with OCLGRIND_DATA_RACES and OCLGRIND_CHECK_API, reports
# data races and API misuse. Registered through an ICD file of our own (OCL_ICD_VENDORS), so it is
# the only platform: the runtime must come up on OpenCL 1.2 (no 2.0-only entry point: before,
# Runtime hung in clCreateCommandQueueWithProperties), and tiny renders of every DSM storage, the
# shadow cache fill, shadow rays and the binary shadow map must finish with no report, and so must
# packets of 4, 8 and 16 lanes, whose images must equal one lane's.
# -cl-opt-disable: Oclgrind's LLVM cannot run the noalias-scope intrinsics that inlining of
# `restrict` arguments emits. Usage: oclgrind.sh SOMBRA_CLI WORK_DIR. Exit 77 (skipped) without Oclgrind.
set -euo pipefail
cli=$1 work=$2
icd=/usr/lib/oclgrind/liboclgrind-rt-icd.so
[ -f "$icd" ] || { echo "oclgrind.sh: Oclgrind is not installed ($icd): skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
echo "$icd" >"$work/oclgrind.icd"
export OCL_ICD_VENDORS="$work" OCLGRIND_DATA_RACES=1 OCLGRIND_CHECK_API=1 OCLGRIND_BUILD_OPTIONS=-cl-opt-disable
cat >"$work/tiny.json" <<'JSON'
{"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "image": {"width": 8, "height": 8},
 "volumes": [{"generator": {"type": "sphere", "size": 8}, "transform": {"scale": 0.1},
              "transfer_function": {"rgb_points": [0, 1, 1, 1, 1, 1, 0.5, 0.2], "opacity_points": [0, 0, 1, 0.5]}}],
 "lights": [{"type": "directional", "direction": [0, -1, -1]}]}
JSON
timeout 60 "$cli" devices | tee "$work/devices.txt"
grep -q "Oclgrind.*OpenCL C 1.2" "$work/devices.txt" || { echo "oclgrind.sh: Oclgrind's 1.2 device not listed"; exit 1; }
status=0
run() {  # one render; any line that is not sombra's own is an Oclgrind report
    local name=$1; shift
    if ! timeout 300 "$cli" render "$work/tiny.json" -o "$work/$name.png" --device 0 "$@" 2>"$work/$name.log"; then
        echo "FAIL $name (exit $?): $*"; cat "$work/$name.log"; status=1; return
    fi
    if grep -v '^sombra: ' "$work/$name.log" | grep -q '[^[:space:]]'; then
        echo "FAIL $name: Oclgrind reports"; head -40 "$work/$name.log"; status=1; return
    fi
    echo "ok   $name: $*"
}
run none --shadows none
for storage in atlas chunked chunked-ondemand compact; do
    run "dsm-$storage" --shadows dsm --dsm-res 16 --dsm-storage "$storage" --shadow-cache off
done
run dsm-native --shadows dsm --dsm-res 16 --dsm-lookup native --shadow-cache off
run cache-fill --shadows dsm --dsm-res 16 --shadow-cache on
run rays --shadows rays --shadow-cache off
run shadowmap --shadows shadowmap --dsm-res 16 --shadow-cache off
# Packets of 4, 8 and 16 lanes (cl/lanes.h): no report, and the image of one lane. Before lmin and
# lclamp, Oclgrind's min(int4, int) gave lanes 1-3 garbage (tests/portability/oclgrind_min_scalar.cl):
# out-of-bounds reads in dsm_build, wrong voxels elsewhere.
for shadows in dsm rays lowpass; do
    res=(); [ "$shadows" = dsm ] && res=(--dsm-res 16)
    for lanes in 1 4 8 16; do
        run "$shadows-lanes$lanes" --shadows "$shadows" "${res[@]}" --shadow-cache off --lanes "$lanes"
        if [ "$lanes" != 1 ] && [ -f "$work/$shadows-lanes$lanes.png" ] &&
           ! cmp -s "$work/$shadows-lanes1.png" "$work/$shadows-lanes$lanes.png"; then
            echo "FAIL $shadows-lanes$lanes: the image differs from one lane's"; status=1
        fi
    done
done
exit $status
