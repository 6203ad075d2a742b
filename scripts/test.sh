#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs what is missing, builds, and runs the whole test suite on the default OpenCL device
# (PoCL's CPU device on a machine without a GPU).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
start=$(date +%s)
# CI's main build includes the MPI option (`ctest -L mpi`: scripts/mpi-check.sh); the core build
# below stays without MPI and the GIS stack.
export TERRACL_MPI=${TERRACL_MPI:-ON}
bash scripts/build.sh
echo "test.sh: build took $(( $(date +%s) - start )) s"
start=$(date +%s)
# Under CI a missing device must fail the kernel tests, never skip them.
export CI=${CI:-false}
(cd "${BUILD_DIR:-build}" && ctest --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 900)
echo "test.sh: tests took $(( $(date +%s) - start )) s"
# The core build without the GIS stack (TERRACL_CORE_ONLY) and its test subset (scripts/core-check.sh).
if [ "${SKIP_CORE:-0}" != "1" ]; then
  start=$(date +%s)
  bash scripts/core-check.sh
  echo "test.sh: core build + tests took $(( $(date +%s) - start )) s"
fi
# libFuzzer smoke run (ASan + UBSan) of the raster readers, the edit-script and pipeline parsers, in
# its own small build folder (only the sources the harnesses need; docs/reliability.md).
if [ "${SKIP_FUZZ:-0}" != "1" ]; then
  start=$(date +%s)
  FUZZ_SECONDS=${FUZZ_SECONDS:-10} bash scripts/fuzz.sh
  echo "test.sh: fuzzing (build + run) took $(( $(date +%s) - start )) s"
fi
