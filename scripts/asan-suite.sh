#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The whole GoogleTest suite under AddressSanitizer + UndefinedBehaviorSanitizer, in its own build
# folder (build-asan, -DTERRACL_SANITIZE=ON): the library, the CLI the tests start and the tests.
# Slow (every source at -O1 with instrumentation; the suite runs ~3x slower): not part of CI, see
# docs/reliability.md. Usage: nice bash scripts/asan-suite.sh [gtest filter]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${ASAN_BUILD_DIR:-build-asan}
FILTER=${1:-*}
start=$(date +%s)
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DTERRACL_SANITIZE=ON -DTERRACL_BUILD_BENCHMARKS=OFF -DTERRACL_BUILD_PYTHON=OFF \
  $(command -v ccache >/dev/null && echo -DCMAKE_CXX_COMPILER_LAUNCHER=ccache) >/dev/null
cmake --build "$BUILD" -j "${JOBS:-2}" --target terracl_cli terracl_tests
echo "asan-suite.sh: build took $(( $(date +%s) - start )) s"
start=$(date +%s)
# PoCL's OpenCL runtime, LLVM and the drivers behind it are not built with ASan: their leaks at
# exit are suppressed by library (tests/asan/lsan.supp says which and why); reports in our code
# stop the run. ASan's own allocator cannot return memory to PoCL's kernel compiler threads
# sooner, so the heap limit is off (allocator_may_return_null: a refused size is our error path).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:fast_unwind_on_malloc=0:detect_odr_violation=0}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/asan/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:suppressions=$PWD/tests/asan/ubsan.supp}
export GDAL_NUM_THREADS=1 OIIO_THREADS=1
"$BUILD/terracl_tests" --gtest_filter="$FILTER" --gtest_brief=1 2>&1 | tee "$BUILD/asan-suite.log" | tail -60
status=${PIPESTATUS[0]}
echo "asan-suite.sh: tests took $(( $(date +%s) - start )) s, exit $status"
exit "$status"
