#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs every Debian package the build, tests and demo need. Idempotent and non-interactive:
# packages already installed are skipped, and `apt-get update` runs at most once per call.
set -euo pipefail

PACKAGES=(
  cmake g++ make pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers clinfo oclgrind
  libopenimageio-dev openimageio-tools libopenexr-dev libpng-dev
  libgdal-dev gdal-bin
  libtiff-dev  # raw tile writes of tiled GeoTIFFs (docs/scale.md, "MPI speed-up")
  libopenmpi-dev openmpi-bin
  libflann-dev liblz4-dev
  libeigen3-dev libcli11-dev nlohmann-json3-dev libfmt-dev
  libhypre-dev libopenmpi-dev openmpi-bin  # -DTERRACL_MPI=ON: reconstruct --solver hypre (docs/scale.md)
  libgtest-dev libbenchmark-dev
  libtinygltf-dev
  libcpp-httplib-dev libjs-three
  chromium chromium-driver python3-selenium python3-gdal python3-numpy
  python3-rasterio python3-xarray  # python/tests/test_interop.py: rasterio and xarray round trips (docs/python.md)
  clang libclang-rt-14-dev
  dpkg-dev file lintian  # lintian: the .debs follow Debian policy (scripts/package-check.sh)
  strace  # fault injection in the tests: ENOSPC / EIO on an output's writes and renames (docs/reliability.md)
  pybind11-dev python3-dev python3-pytest python3-setuptools python3-pip
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
