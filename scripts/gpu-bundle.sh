#!/usr/bin/env bash
# Packs this build for a lent GPU machine (issue 33's GPU check), which has CUDA but none of the
# Debian packages the build links and no network: the CLI, the test binary, the image comparison,
# the two benches and ctest's files, with every shared library they load that is not glibc's or
# the C++ runtime's (the lent machine's are newer), and the ICD loader. scripts/gpu-remote.sh
# unpacks it there.
#
#   scripts/gpu-bundle.sh [DIR]      (default .gpu-bundle)
set -euo pipefail
cd "$(dirname "$0")/.."
dir=$(realpath -m "${1:-.gpu-bundle}")
bins="build/sombra build/tests/sombra_tests build/tests/sombra_compare_images build/bench/sombra_bench_camera build/bench/sombra_bench_dsm"
for b in $bins; do [ -x "$b" ] || { echo "gpu-bundle: $b is not built (scripts/build.sh)" >&2; exit 1; }; done
rm -rf "$dir" && mkdir -p "$dir/lib"
system='/(libc|libm|libmvec|libpthread|libdl|librt|libresolv|ld-linux-x86-64|libstdc\+\+|libgcc_s)\.so'
# OpenImageIO's video, camera-raw, DICOM, HEIF and OpenCV libraries (and the 250 MB they load in
# turn: GDAL, codecs) are never called by sombra: stand-ins that define their symbols and load
# nothing (scripts/stub_library.py) keep the bundle under what a lent machine takes (64 MB)
never_called='/lib(opencv_[a-z]+|avcodec|avformat|avutil|swscale|swresample|heif|raw_r|dcm[a-z]+|oflog|ofstd)\.so'
# shellcheck disable=SC2086  # the binary list is words without spaces
ldd $bins | awk '$2 == "=>" && $3 ~ /^\// { print $3 }' | sort -u | { grep -E "$never_called" || true; } |
  while read -r lib; do python3 scripts/stub_library.py "$lib" "$dir/lib"; done
# shellcheck disable=SC2086
LD_LIBRARY_PATH="$dir/lib" ldd $bins | awk '$2 == "=>" && $3 ~ /^\// { print $3 }' | sort -u | grep -Ev "$system" |
  { grep -v "^$dir/lib/" || true; } | while read -r lib; do cp -L "$lib" "$dir/lib/"; done
cp -L "$(ldconfig -p | awk '/libOpenCL\.so\.1 / { print $NF; exit }')" "$dir/lib/"
# the bundle alone must load: every library resolves into it (or to glibc and the C++ runtime)
# shellcheck disable=SC2086
if LD_LIBRARY_PATH="$dir/lib" ldd $bins | awk '$2 == "=>" { print $3 }' | grep -Ev "$system" | grep -v "^$dir/lib/" | grep .; then
  echo "gpu-bundle: the libraries above resolve outside the bundle" >&2; exit 1
fi
# ctest's files: the test lists catch_discover_tests wrote, with this checkout's absolute paths
# (gpu-remote.sh links this path to the checkout there)
ctest_files=$(find build -path build/CMakeFiles -prune -o \( -name CTestTestfile.cmake -o -name '*_tests*.cmake' -o -name '*_include*.cmake' \) -print)
# shellcheck disable=SC2086
tar --transform "s,^lib,$(basename "$dir")/lib," -cf - $bins $ctest_files -C "$dir" lib | xz -T2 -6 >"$dir/bundle.tar.xz"
rm -rf "$dir/lib"
pwd -P >"$dir/source-dir"
du -sh "$dir"
