#!/usr/bin/env bash
# Installs iblbake's build and test dependencies from Debian's archive
# (Debian 12). Does nothing when everything is already installed.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libopenimageio-dev libopenexr-dev libpng-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib time
  nlohmann-json3-dev libtbb-dev libssl-dev libcli11-dev
  libgtest-dev libbenchmark-dev
  blender blender-data
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "install_deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
