#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Configures and builds terracl (Release) into build/. Used by demo.sh, test.sh and bench.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}
LAUNCHER=()
# ccache is optional: it only speeds up rebuilds (and parallel worktrees) when it is installed.
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(cd .. && pwd)}
  LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
# TERRACL_MPI=ON: tiled runs over MPI ranks (OpenMPI; test.sh turns it on so CI builds and tests it).
# Unset, an existing build folder keeps its setting (demo.sh after test.sh does not rebuild everything).
MPI_OPT=()
if [ -n "${TERRACL_MPI:-}" ]; then
  MPI_OPT=(-DTERRACL_MPI="$TERRACL_MPI")
elif [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  MPI_OPT=(-DTERRACL_MPI=OFF)
fi
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release "${MPI_OPT[@]}" "${LAUNCHER[@]}" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
