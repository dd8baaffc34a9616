#!/usr/bin/env bash
# sombra on a second real OpenCL implementation: Intel's OpenCL CPU runtime (PyPI intel-opencl-rt
# 2026.2.0, scripts/intel-opencl.sh), beside PoCL through an ICD folder of the two. The wheel's
# oneTBB is preloaded (Debian's TBB, which OpenVDB loads, hides Intel's device otherwise): both
# devices must be listed, a CLI render with Intel as the only platform must finish, and images of
# every technique on Intel must match PoCL's within max |Δ| 2e-3 and mean |Δ| 1e-5 (RGBA, the
# kernel-vs-reference tests' bounds; tests/portability/compare_devices.py, 32², the two devices
# rendering at once): on the default and smoke scenes (the ctest: the two share their programs;
# cold, both drivers compile for most of its 188 s), or with --all-scenes on every scene of
# data/scenes (each scene has programs of its own: 1,792 s cold, 160 s warm). Times on 2 cores
# that other work kept busy (load 4–6). Measured: max |Δ| 2.0e-5 (default, smoke), 1.8e-4 (every
# scene: head_in_fog, shadowmap), mean 1.2e-7 and 1.0e-7. Never downloads: exit 77 (skipped) when
# .intel-opencl/ is not installed (CI installs it, .ci/run) or the Python module is not built.
# Usage: intel.sh SOMBRA_CLI PYTHON_MODULE_DIR WORK_DIR [--all-scenes]
set -euo pipefail
cli=$1 module=$2 work=$3
scenes=(--scenes default smoke)
[ "${4:-}" = --all-scenes ] && scenes=()
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
env=$("$root/scripts/intel-opencl.sh" --env --pocl --no-install)  # exit 77 when not installed
eval "$env"
ls "$module"/sombra*.so >/dev/null 2>&1 || { echo "intel.sh: the Python module is not built in $module: skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
timeout 60 "$cli" devices | tee "$work/devices.txt"
grep -q "Intel(R) OpenCL" "$work/devices.txt" || { echo "intel.sh: Intel's device is not listed (a TBB clash?)"; exit 1; }
grep -q "Portable Computing Language" "$work/devices.txt" || { echo "intel.sh: PoCL's device is not listed"; exit 1; }
# the CLI with Intel as the only platform (no device, no render)
OCL_ICD_VENDORS=$("$root/scripts/intel-opencl.sh" --no-install) timeout 300 "$cli" render "$root/data/scenes/smoke.json" \
    -o "$work/smoke.exr" --width 32 --height 32 --dsm-res 64
PYTHONPATH=$module /usr/bin/python3 "$here/compare_devices.py" Intel "Portable Computing Language" --size 32 \
    --max-abs 2e-3 --mean-abs 1e-5 "${scenes[@]}"
