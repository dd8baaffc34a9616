#!/usr/bin/env bash
# Installs sombra's Debian packages (Debian 12 "bookworm"): the one list, below. Installs only
# what is missing. Run as root (or with sudo available). `--list` prints the list (one package a
# line) for scripts/check-deps.sh.
set -euo pipefail
packages=(
  # toolchain
  build-essential cmake pkg-config binutils
  # OpenCL: PoCL (CPU device), ICD loader, C and C++ headers
  pocl-opencl-icd ocl-icd-opencl-dev opencl-clhpp-headers opencl-c-headers clinfo
  # a second OpenCL implementation: Oclgrind, a simulated OpenCL 1.2 device that checks every
  # access and reports data races (tests/portability/oclgrind.sh)
  oclgrind
  # NVIDIA's target without a GPU (tests/portability/ptx_check.sh): clang-15 (PoCL's, named here
  # as the test calls it) and libclc's OpenCL built-ins for NVPTX; ptxas is the CUDA toolkit's
  clang-15 libclc-15
  # maths, images, tests, JSON, command line
  libglm-dev libopenimageio-dev catch2 nlohmann-json3-dev libcli11-dev
  # the program cache's digests (xxHash, header-only)
  libxxhash-dev
  # volume and mesh formats (OBJ: tinyobjloader's header; nifti1_io.h includes nifti1.h, which is in libnifti2-dev)
  libniftiio-dev libnifti2-dev libznz-dev libzip-dev zlib1g-dev libtinyobjloader-dev
  # the Python module (python/): Debian's python3 with its numpy 1.24 and pytest; venv and pip for
  # scripts/python-deps.sh (pybind11 ≥ 2.12, which numpy 2 needs, and numpy 2 come from PyPI)
  python3-dev python3-numpy python3-pytest python3-venv python3-pip
  # the benches' plots (bench/plot_error_pareto.py, bench/plot_lowpass.py)
  python3-matplotlib
  # OpenVDB (.vdb; its headers include Boost's, which libopenvdb-dev does not pull in) and ITK's
  # ImageIO (NRRD, MetaImage, TIFF, DICOM through GDCM)
  libopenvdb-dev libboost-dev libtbb-dev libimath-dev libinsighttoolkit5-dev
  # sanitizer build and fuzzing (scripts/sanitize.sh, scripts/fuzz.sh): clang, libFuzzer and the
  # sanitizer runtimes, llvm-symbolizer for readable reports
  clang libclang-rt-dev llvm
  # `sombra view` (issue 31): cpp-httplib's HTTP server; its browser test drives Debian's chromium
  # headless through chromium-driver and selenium (tests/view/test_view_browser.py)
  libcpp-httplib-dev chromium chromium-driver python3-selenium
  # `mpirun -np N sombra render … --distributed` (issue 32, docs/distributed.md): Open MPI's
  # library and headers (CMake's FindMPI) and its mpirun
  libopenmpi-dev openmpi-bin
)
if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${packages[@]}"
  exit 0
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
else
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "install-deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi
"$(dirname "$0")/python-deps.sh"
