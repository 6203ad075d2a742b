#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Slices of the release test suite against a CLI whose chosen modules are built with ASan + UBSan
# (the rest of the library uninstrumented): what fits a loaded 2-core machine when the whole
# sanitized build (scripts/asan-suite.sh, ~150 units) does not. Needs the release build in build/.
# The tests start build/bin/terracl, so the hybrid CLI stands in for it during the run and the
# release one is put back on every exit. Any sanitizer report in a CLI child is a file under
# $ASAN_BUILD_DIR/reports and exit code 99, which no test expects. docs/reliability.md has the figures.
#   nice bash scripts/asan-cli-slices.sh 'Reliability*' 'StageMemory*'
#   ASAN_UNITS="core/*.cpp io/npy.cpp" nice bash scripts/asan-cli-slices.sh 'Npy*'   # units under host/src
set -euo pipefail
cd "$(dirname "$0")/.."
ASAN=${ASAN_BUILD_DIR:-build-asan}
UNITS=${ASAN_UNITS:-core/*.cpp io/*.cpp}
cmake -S . -B "$ASAN" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DTERRACL_SANITIZE=ON -DTERRACL_BUILD_BENCHMARKS=OFF -DTERRACL_BUILD_PYTHON=OFF \
  $(command -v ccache >/dev/null && echo -DCMAKE_CXX_COMPILER_LAUNCHER=ccache) >/dev/null
objs=()
for u in $UNITS; do
  for f in host/src/$u; do objs+=("CMakeFiles/terracl_objects.dir/$f.o"); done
done
start=$(date +%s)
make -C "$ASAN" -j "${JOBS:-2}" -f CMakeFiles/terracl_objects.dir/build.make "${objs[@]}"
echo "asan-cli-slices.sh: ${#objs[@]} instrumented units ($UNITS) took $(( $(date +%s) - start )) s"
# The release CLI's link line with the instrumented objects first: the archive's copies of those
# units are then never pulled in.
link=$(cat build/CMakeFiles/terracl_cli.dir/link.txt)
link=${link/-o bin\/terracl/-fsanitize=address,undefined -o ../$ASAN/bin/terracl ${objs[*]/#/../$ASAN/}}
mkdir -p "$ASAN/bin" "$ASAN/reports"
(cd build && eval "$link")
mv build/bin/terracl build/bin/terracl.release
trap 'mv -f build/bin/terracl.release build/bin/terracl' EXIT
cp "$ASAN/bin/terracl" build/bin/terracl
reports=$PWD/$ASAN/reports
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1:fast_unwind_on_malloc=0:detect_odr_violation=0:exitcode=99:log_path=$reports/asan
export LSAN_OPTIONS=suppressions=$PWD/tests/asan/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:exitcode=99:log_path=$reports/ubsan:suppressions=$PWD/tests/asan/ubsan.supp
export GDAL_NUM_THREADS=1 OIIO_THREADS=1
status=0
for f in "${@:-Reliability*}"; do
  start=$(date +%s)
  rc=0
  build/terracl_tests --gtest_filter="$f" --gtest_brief=1 >"$ASAN/slice.log" 2>&1 || rc=$?
  tail -3 "$ASAN/slice.log"
  echo "asan-cli-slices.sh: '$f': exit $rc in $(( $(date +%s) - start )) s; sanitizer reports so far: $(ls "$reports" | wc -l)"
  [ "$rc" = 0 ] || status=1
done
[ -z "$(ls "$reports")" ] || status=1
exit $status
