#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# libFuzzer campaigns over the raster readers, the edit-script parser and the pipeline parser
# (ASan + UBSan), from the seed corpus in tests/fuzz/corpus/<target>.
#   scripts/fuzz.sh               # CI: build the three targets, run each for FUZZ_SECONDS (default 20)
#   FUZZ_SECONDS=3600 scripts/fuzz.sh [target ...]   # a longer campaign (nice it on a shared machine)
# New inputs go to build-fuzz/corpus/<target> (the seeds are never modified); a crash, leak or
# timeout leaves its input in build-fuzz/findings/<target> and fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${FUZZ_BUILD_DIR:-build-fuzz}
SECONDS_PER_TARGET=${FUZZ_SECONDS:-20}
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(fuzz_raster fuzz_edit_script fuzz_pipeline)

start=$(date +%s)
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  # fuzz_edit_script links the device code it never reaches from the main build's library.
  lib="$(cd "${BUILD_DIR:-build}" 2>/dev/null && pwd)/libterracl.a"
  cmake -S tests/fuzz -B "$BUILD" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTERRACL_LIBRARY="$lib" "${launcher[@]}" >/dev/null
fi
cmake --build "$BUILD" -j "${JOBS:-$(nproc)}" --target "${TARGETS[@]}"
echo "fuzz.sh: build took $(( $(date +%s) - start )) s"

# Full unwinding on malloc so that leaks in third-party code match tests/fuzz/lsan.supp.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:fast_unwind_on_malloc=0}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# GDAL and OIIO are not built with the sanitizers; keep their own caches and threads quiet.
export GDAL_NUM_THREADS=1 OIIO_THREADS=1 GDAL_CACHEMAX=64
# terracl's own size checks refuse what does not fit in 1 GiB (a header may claim 30000^2 cells
# of a machine's 15 GB), so the 2 GB malloc limit below catches only allocations that bypass them
# (a third-party reader trusting a header: the EXR attributes, the TIFF block table).
export TERRACL_MAX_MEMORY=${TERRACL_MAX_MEMORY:-1G}
status=0
for t in "${TARGETS[@]}"; do
  seeds=tests/fuzz/corpus/${t#fuzz_}
  work=$BUILD/corpus/${t#fuzz_}
  findings=$BUILD/findings/${t#fuzz_}
  mkdir -p "$work" "$findings"
  log=$BUILD/$t.log
  echo "fuzz.sh: $t for ${SECONDS_PER_TARGET} s"
  if ! "$BUILD/$t" "$work" "$seeds" -max_total_time="$SECONDS_PER_TARGET" -timeout=60 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
       -max_len=65536 -artifact_prefix="$findings/" -print_final_stats=1 >"$log" 2>&1; then
    echo "fuzz.sh: $t FOUND A PROBLEM (input in $findings):"
    tail -40 "$log"
    status=1
  fi
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|cov: " "$log" | tail -3 || true
done
echo "fuzz.sh: done in $(( $(date +%s) - start )) s"
exit $status
