#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Run HERE (a Debian machine with apt): downloads the .deb files the core build needs on the GPU
# machine (no package registry there) into .gpu/ (git-ignored), to be carried with the device
# tool's `carry: [".gpu"]` and unpacked by scripts/gpu-check.sh. See docs/gpu.md.
set -euo pipefail
cd "$(dirname "$0")/.."
PKGS=(ocl-icd-libopencl1 ocl-icd-opencl-dev opencl-headers opencl-c-headers opencl-clhpp-headers
      nlohmann-json3-dev libfmt-dev libeigen3-dev libcli11-dev googletest)
mkdir -p .gpu
rm -f .gpu/*.deb
(cd .gpu && apt-get download "${PKGS[@]}")
ls -l .gpu
bytes=$(du -cb .gpu/*.deb | tail -1 | cut -f1)
echo "gpu-pack: ${#PKGS[@]} packages, total $((bytes / 1024)) KiB in .gpu/ (carry limit 64 MiB)"
[ "$bytes" -lt $((64 * 1024 * 1024)) ] || { echo "gpu-pack: over the 64 MiB carry limit" >&2; exit 1; }
