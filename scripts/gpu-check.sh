#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Run THERE (the GPU machine: compiler, CMake, NVIDIA driver, no package registry), in the repo
# root with .gpu/ carried (made HERE by scripts/gpu-pack.sh). One command: unpacks the .debs into a
# prefix, points the ICD loader at the vendor's OpenCL library, builds the core
# (TERRACL_CORE_ONLY), runs the core tests and the core benchmarks. Logs go to $OUT when set.
#   TERRACL_ICD_LIB   vendor OpenCL library (default libnvidia-opencl.so.1; libpocl.so.2 to try it
#                     on a PoCL machine)
#   JOBS              build parallelism (default: all cores)
#   BUILD_DIR         build folder (default build-gpu)
#   QUICK=1           small benchmark sizes only (a rehearsal on a CPU device)
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
PREFIX=${PREFIX:-/tmp/terracl-gpu-prefix}
BUILD=${BUILD_DIR:-build-gpu}
JOBS=${JOBS:-$(nproc)}
LOGS=${OUT:-$ROOT/$BUILD/logs}
ICD_LIB=${TERRACL_ICD_LIB:-libnvidia-opencl.so.1}
mkdir -p "$LOGS" && rm -f "$LOGS/summary.txt" "$LOGS/bench.txt"
log() { echo "gpu-check: $*" | tee -a "$LOGS/summary.txt"; }

ls .gpu/*.deb >/dev/null 2>&1 || { echo "gpu-check: no .gpu/*.deb (run scripts/gpu-pack.sh here, carry .gpu)" >&2; exit 1; }
rm -rf "$PREFIX" && mkdir -p "$PREFIX"
for d in .gpu/*.deb; do dpkg -x "$d" "$PREFIX" || { echo "gpu-check: cannot unpack $d" >&2; exit 1; }; done
ARCH_LIB=$PREFIX/usr/lib/$(gcc -dumpmachine 2>/dev/null || echo x86_64-linux-gnu)

# The ICD loader (ocl-icd) reads vendor files from OCL_ICD_VENDORS instead of /etc/OpenCL/vendors.
mkdir -p "$PREFIX/vendors"
echo "$ICD_LIB" > "$PREFIX/vendors/vendor.icd"
export OCL_ICD_VENDORS=$PREFIX/vendors
export LD_LIBRARY_PATH=$ARCH_LIB${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
log "ICD $ICD_LIB; loader $(ls "$ARCH_LIB"/libOpenCL.so.1* 2>/dev/null | head -1)"
if [[ "$ICD_LIB" == libnvidia* ]]; then
  found=$(ldconfig -p 2>/dev/null | grep -m1 "$ICD_LIB" || true)
  log "NVIDIA OpenCL library: ${found:-NOT in the ld cache}; nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -1)"
fi

log "configure ($BUILD, prefix $PREFIX)"
cmake -S . -B "$BUILD" -DTERRACL_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$PREFIX/usr" -DCMAKE_DISABLE_FIND_PACKAGE_GTest=ON \
  -DTERRACL_GTEST_SOURCE="$PREFIX/usr/src/googletest" -DOpenCL_INCLUDE_DIR="$PREFIX/usr/include" \
  -DOpenCL_LIBRARY="$ARCH_LIB/libOpenCL.so" -DFMT_INCLUDE_DIR="$PREFIX/usr/include" \
  ${CMAKE_EXTRA:-} > "$LOGS/configure.log" 2>&1 || { tail -30 "$LOGS/configure.log"; log "configure FAILED"; exit 1; }
log "build -j$JOBS"
cmake --build "$BUILD" -j"$JOBS" --target terracl_cli terracl_tests > "$LOGS/build.log" 2>&1 ||
  { tail -40 "$LOGS/build.log"; log "build FAILED"; exit 1; }

TERRACL=$BUILD/bin/terracl
"$TERRACL" devices 2>&1 | tee "$LOGS/devices.txt"
status=0
log "core tests"
(cd "$BUILD" && ctest --output-on-failure --timeout 900) > "$LOGS/tests.log" 2>&1 && log "core tests PASSED" ||
  { status=1; tail -60 "$LOGS/tests.log"; log "core tests FAILED (see tests.log)"; }
grep -E '^\[  (PASSED|FAILED) |tests? ran' "$LOGS/tests.log" | tee -a "$LOGS/summary.txt"

bench() {  # name size repeats [args...]
  local name=$1 n=$2 reps=$3; shift 3
  log "bench $name --size $n --repeats $reps $*"
  "$TERRACL" bench "$name" --size "$n" --repeats "$reps" "$@" 2>&1 | tee -a "$LOGS/bench.txt" | tee -a "$LOGS/summary.txt" ||
    { status=1; log "bench $name $n FAILED"; }
}
if [ "${QUICK:-0}" = 1 ]; then
  bench reconstruct 257 3; bench edit 257 3; bench erode 256 3
else
  bench reconstruct 1025 10; bench reconstruct 4097 5; bench edit 1025 10; bench erode 1024 10
  # Refinement cost, render against the host path, and where reconstruct's time goes.
  bench reconstruct 1025 5 --set fixed=0.0000038 --set refine=off
  bench reconstruct 1025 5 --set fixed=0.0000038 --set refine=auto
  bench reconstruct 4097 3 --set refine=auto
  bench render 8192 3
  log "profile: TERRACL_MG_PROFILE=1 bench reconstruct --size 4097 --repeats 1"
  TERRACL_MG_PROFILE=1 "$TERRACL" bench reconstruct --size 4097 --repeats 1 >> "$LOGS/bench.txt" 2>&1 || status=1
fi
log "done (status $status); logs in $LOGS"
exit $status
