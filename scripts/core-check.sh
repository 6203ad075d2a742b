#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The core build (TERRACL_CORE_ONLY: no GDAL/OIIO/OpenEXR/FLANN/tinygltf/httplib; docs/gpu.md) and
# its test subset, in its own build folder beside the full build. Run by scripts/test.sh in CI.
#   CORE_BUILD_DIR  build folder (default build-core-ci; gpu-check.sh rehearsals use build-core)
#   CORE_OPT        optimisation flags of this build (default -O1: 34 % less compile CPU than
#                   Release's -O3; the kernels run on the OpenCL device, so the host code's speed
#                   hardly moves the tests' time; docs/performance.md has the figures)
#   JOBS            build parallelism (default: all cores)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${CORE_BUILD_DIR:-build-core-ci}
JOBS=${JOBS:-$(nproc)}
LAUNCHER=()
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(cd .. && pwd)}
  LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
start=$(date +%s)
cmake -S . -B "$BUILD" -DTERRACL_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_FLAGS_RELEASE="${CORE_OPT:--O1} -DNDEBUG" "${LAUNCHER[@]}" >/dev/null
cmake --build "$BUILD" -j "$JOBS" --target terracl_cli terracl_tests
echo "core-check: build took $(( $(date +%s) - start )) s"
start=$(date +%s)
(cd "$BUILD" && ctest --output-on-failure --timeout 900)
"$BUILD/bin/terracl" bench reconstruct --size 129 --repeats 1 --set refine=auto | grep -E 'max_error|refinement'
echo "core-check: tests took $(( $(date +%s) - start )) s"
