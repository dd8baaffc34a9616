#!/usr/bin/env bash
# Runs the GPU check on a lent machine from the bundle scripts/gpu-bundle.sh made (issue 33): it
# unpacks the build, puts the bundle's libraries first on the library path, registers NVIDIA's
# OpenCL driver with the ICD loader when no vendor file names it, links the build's source path to
# this checkout (ctest's files hold absolute paths), and runs scripts/gpu-check.sh with the images
# rendered into a folder. Everything comes back in OUT_DIR: the report, ctest's log and the images.
#
#   scripts/gpu-remote.sh [OUT_DIR] [--extra-only | extra gpu-check.sh arguments …]
#
# --extra-only: only .gpu-extra.sh (a second call in one lease, for its own questions).
# A file .gpu-extra.sh (carried beside .gpu-bundle), if there, runs after the check with the same libraries and driver
# (a lease's own diagnostics; its output comes back as OUT_DIR/extra.txt).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-${OUT:-gpu-out}}
shift || true
mkdir -p "$out"
bundle=.gpu-bundle
tar -xJf $bundle/bundle.tar.xz   # build/… and $bundle/lib
export LD_LIBRARY_PATH="$PWD/$bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
source_dir=$(cat $bundle/source-dir)
if [ "$(pwd -P)" != "$source_dir" ] && [ ! -e "$source_dir" ]; then
  mkdir -p "$(dirname "$source_dir")" && ln -s "$(pwd -P)" "$source_dir"
fi
# NVIDIA's driver, registered with the ICD loader when no vendor file names it
icd_note="a vendor file names NVIDIA's driver"
if ! grep -qs nvidia /etc/OpenCL/vendors/*; then
  lib=$(find /usr/local/nvidia /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib -maxdepth 3 -name 'libnvidia-opencl.so*' 2>/dev/null | sort | head -n 1)
  icd_note="no vendor file names NVIDIA's driver; found: ${lib:-none}"
  if [ -n "$lib" ]; then
    mkdir -p /tmp/sombra-icd && echo "$lib" >/tmp/sombra-icd/nvidia.icd
    export OCL_ICD_VENDORS=/tmp/sombra-icd
  fi
fi
{
  echo "== machine"; nvidia-smi -L 2>&1; nproc; uname -r
  echo "== OpenCL vendor files"; ls -l /etc/OpenCL/vendors 2>&1; echo "$icd_note"
  echo "== libraries not found"; ldd build/sombra build/tests/sombra_tests | grep "not found" || echo none
} 2>&1 | tee "$out/machine.txt"
images=/tmp/sombra-gpu-images
status=0
if [ "${1:-}" != --extra-only ]; then
  scripts/gpu-check.sh --no-build --device gpu --images-to "$images" --report "$out/gpu-check.md" "$@"
  status=$?
fi
# a lease's own questions, in the same environment: .gpu-extra.sh if it was carried
[ -f .gpu-extra.sh ] && timeout "${GPU_EXTRA_LIMIT:-150}" bash .gpu-extra.sh >"$out/extra.txt" 2>&1
[ -d "$images" ] && tar -czf "$out/images.tar.gz" -C "$images" . 2>/dev/null
exit $status
