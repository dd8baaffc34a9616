#!/usr/bin/env bash
# Installs sombra's Debian packages (Debian 12). Run as root (or with sudo available).
set -euo pipefail
packages=(
  build-essential cmake pkg-config binutils
  pocl-opencl-icd ocl-icd-opencl-dev opencl-clhpp-headers opencl-c-headers clinfo
  libglm-dev libopenimageio-dev catch2 nlohmann-json3-dev libcli11-dev
  libniftiio-dev libznz-dev libzip-dev zlib1g-dev libassimp-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
