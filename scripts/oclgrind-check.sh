#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs every OpenCL stage of terracl on small grids under oclgrind (a simulated, strict OpenCL 1.2
# device) with --data-races --uninitialized and fails on any report: a read of memory nobody wrote,
# an out-of-bounds access or a data race. PoCL forgives those; a GPU gives garbage.
#   scripts/oclgrind-check.sh [BUILD_DIR]      (ctest label `oclgrind` runs it)
#   ONLY=^wide_ scripts/oclgrind-check.sh     (only the cases whose name matches)
# Each case's diagnostics go to OUT/<case>.log; the script prints the first lines of any non-empty
# log. Sizes are small (33..65 cells a side, few cycles/steps): the whole run takes ~2 min on 2 cores
# (the six wide-shape cases: 47 s wall, load average ~20, `ONLY=^wide_ bash scripts/oclgrind-check.sh`).
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
T=$(cd "$BUILD" && pwd)/bin/terracl
command -v oclgrind >/dev/null || { echo "oclgrind-check: oclgrind is not installed (apt-get install oclgrind)"; exit 1; }
[ -x "$T" ] || { echo "oclgrind-check: $T not built"; exit 1; }
OUT=$(mktemp -d "${TMPDIR:-/tmp}/terracl-oclgrind.XXXXXX")
export TERRACL_NO_CACHE=1  # oclgrind programs are not cached binaries
unset OCL_PLATFORM OCL_DEVICE OCL_TYPE
# --uninitialized is off by default: Debian 12's oclgrind 21.10 plugin crashes on LLVM 'freeze' and
# mis-tracks vector shuffles (docs/gpu.md); OCLGRIND_FLAGS="--data-races --uninitialized" runs it.
OCLGRIND_FLAGS=${OCLGRIND_FLAGS:---data-races}
fail=0
run() {  # run NAME ARGS... : terracl ARGS under oclgrind; any diagnostic or a non-zero exit fails
  local name=$1
  shift
  # ONLY=REGEX runs the cases whose name matches (e.g. ONLY=^wide_ for the wide launch shape).
  if [ -n "${ONLY:-}" ] && ! [[ $name =~ $ONLY ]]; then return; fi
  local t0=$(date +%s)
  oclgrind $OCLGRIND_FLAGS --max-errors 20 --log "$OUT/$name.log" "$T" -q "$@" >"$OUT/$name.out" 2>&1
  local rc=$?
  if [ $rc -ne 0 ] || [ -s "$OUT/$name.log" ]; then
    echo "oclgrind-check: FAIL $name (exit $rc, $(grep -c '^[A-Z]' "$OUT/$name.log" 2>/dev/null || echo 0) reports): terracl $*"
    head -40 "$OUT/$name.log"
    tail -5 "$OUT/$name.out"
    fail=1
  else
    echo "oclgrind-check: ok   $name ($(($(date +%s) - t0)) s)"
  fi
}
D=data/dem/N44W072.hgt
# A 65^2 crop of the SRTM tile (its own metric cell size) is the input of the raster stages.
"$T" -q crop "$D" -o "$OUT/c65.tif" --x 600 --y 600 --width 65 --height 65 >/dev/null 2>&1 ||
  { echo "oclgrind-check: crop failed"; exit 1; }
"$T" -q crop "$D" -o "$OUT/c45.tif" --x 600 --y 600 --width 45 --height 37 >/dev/null 2>&1

run extract extract "$OUT/c65.tif" -o "$OUT/g.exr"
run extract_central extract "$OUT/c45.tif" --central -o "$OUT/gc.exr"
run reconstruct reconstruct --gradient "$OUT/g.exr" -o "$OUT/r.tif"
run reconstruct_central reconstruct --gradient "$OUT/gc.exr" -o "$OUT/rc.tif"
run reconstruct_jacobi_w reconstruct --gradient "$OUT/g.exr" -o "$OUT/rj.tif" --smoother jacobi --cycle w
run reconstruct_cascade reconstruct --gradient "$OUT/g.exr" -o "$OUT/rk.tif" --cycle cascade
run reconstruct_dirichlet reconstruct --gradient "$OUT/g.exr" -o "$OUT/rd.tif" --border dirichlet --initial "$OUT/c65.tif" --cycle v
run reconstruct_refine reconstruct --gradient "$OUT/g.exr" -o "$OUT/rr.tif" --refine auto
# At 65^2 every coarse level of a cycle runs in the fused work-group kernel (multigrid_coarse.cl):
# its W-cycle path, and the one-launch-per-stage path (smooth9 etc.) that it replaces.
# (45 x 37: four levels, the W-cycle visits level 2 twice; ~4 s CPU each.)
run reconstruct_w reconstruct --gradient "$OUT/gc.exr" -o "$OUT/rw.tif" --cycle w
TERRACL_MG_FUSED=0 run reconstruct_multi_launch reconstruct --gradient "$OUT/gc.exr" -o "$OUT/rm.tif"
# The authoring examples shrunk to 65 cells across over the same extent (metre coordinates stay,
# cell coordinates are scaled), so that every operation lands on the small grid. volcanic_island
# runs without its `fit` operation: with it, oclgrind 21.10 aborted in its own oclgrind::Program
# destructor at exit ("corrupted double-linked list"), after the output was written, zero reports.
for e in volcanic_island canyon cliff mountain_range mountain_chain_tensors; do
  /usr/bin/python3 - "data/examples/$e.json" "$OUT/$e.json" <<'PY'
import json, re, sys
d = json.load(open(sys.argv[1]))
w, h, cell, z = re.fullmatch(r"flat:(\d+)x(\d+)@([0-9.]+)([+-][0-9.]+)?", d["base"]).groups()
w, h, cell = int(w), int(h), float(cell)
k = 64.0 / (w - 1)  # new cells per old cell
in_cells = d.get("units") == "cells"
HORIZONTAL = {"radius", "width", "disc_radius", "wavelength", "falloff", "floor", "feather", "fade"}
def walk(v, key=None):
    if isinstance(v, dict):
        return {k2: walk(x, k2) for k2, x in v.items()}
    if isinstance(v, list):
        if in_cells and len(v) in (2, 3) and all(isinstance(x, (int, float)) for x in v):
            return [x * k for x in v[:2]] + v[2:]
        return [walk(x, key) for x in v]
    if in_cells and key in HORIZONTAL and isinstance(v, (int, float)):
        return v * k
    return v
d["base"] = "flat:65x%d@%g%s" % (max(9, round((h - 1) * k) + 1), cell / k, z or "")
d["operations"] = [walk(o) for o in d["operations"] if o.get("op") != "fit"]
json.dump(d, open(sys.argv[2], "w"))
PY
  run "edit_$e" edit --script "$OUT/$e.json" -o "$OUT/$e.tif"
done
run erode erode "$OUT/c45.tif" -o "$OUT/e.tif" --steps 3
run erode_open erode "$OUT/c45.tif" -o "$OUT/eo.tif" --steps 2 --boundary open --deposit-layer
run erode_thermal erode "$OUT/c45.tif" -o "$OUT/et.tif" --steps 2 --thermal-only
for m in hillshade relief slope shaded-relief; do
  run "render_$m" render "$OUT/c45.tif" -o "$OUT/$m.png" --mode "$m"
done
run render_igor_edges render "$OUT/c45.tif" -o "$OUT/igor.tif" --shading igor --compute-edges
# The perspective ray march (render_view.cl), shadows and haze on, a small picture (~2 s).
run render_perspective render "$OUT/c45.tif" -o "$OUT/persp.png" --mode perspective --size 64x40
# The same with a lake (the crop spans 309..477 m) and the hypsometric ramp: water body, glint,
# shadows on the water; the case above draws the natural material.
run render_perspective_water render "$OUT/c45.tif" -o "$OUT/perspw.png" --mode perspective --size 48x30 \
  --water-level 400 --ramp hypsometric --azimuth 160
for m in aspect tri tpi roughness profile-curvature tangential-curvature; do
  run "render_$m" render "$OUT/c45.tif" -o "$OUT/$m.tif" --mode "$m" --compute-edges
done
# The wide launch shape (GPUs: one work-item per cell in 2D groups, kernels/launch.clh) on the cell
# kernels: gradient, multigrid (red-black and four-colour smoothers, restriction, prolongation,
# Galerkin), tensor fields, render and value rasters. Data races matter most here (red-black / four-colour cells).
TERRACL_LAUNCH=wide run wide_extract extract "$OUT/c65.tif" -o "$OUT/wg.exr"
TERRACL_LAUNCH=wide run wide_extract_central extract "$OUT/c45.tif" --central -o "$OUT/wgc.exr"
TERRACL_LAUNCH=wide run wide_reconstruct reconstruct --gradient "$OUT/wgc.exr" -o "$OUT/wr.tif"
# (Jacobi and the cascade write a second buffer: no race to find; one wide work-item per cell makes
# oclgrind ~3x slower than rows, so they are left to Launch.ReconstructSameBitsInBothShapes.)
TERRACL_LAUNCH=wide run wide_edit_mountain_chain_tensors edit --script "$OUT/mountain_chain_tensors.json" -o "$OUT/wm.tif"
TERRACL_LAUNCH=wide run wide_render_shaded_relief render "$OUT/c45.tif" -o "$OUT/wsr.png" --mode shaded-relief
TERRACL_LAUNCH=wide run wide_render_aspect render "$OUT/c45.tif" -o "$OUT/wa.tif" --mode aspect --compute-edges
if [ $fail -ne 0 ]; then
  echo "oclgrind-check: FAILED (logs in $OUT)"
  exit 1
fi
rm -rf "$OUT"
echo "oclgrind-check: all clean"
