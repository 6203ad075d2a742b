#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Tiled runs over MPI ranks (ctest label `mpi`, docs/scale.md): `mpirun -n 2` and `-n 3`
# (--oversubscribe: CI has 2 cores) give files byte-identical (cmp) to the single-process tiled run,
# for a pipeline with a render sink, the exact tiled fill (depressions across tile borders, a nodata
# lake), the exact tiled D8 accumulation, a crop and a value render, for tiled subcommands, tiled
# amplify, warp, resize, metrics and extract; an
# error on one rank stops every rank with its message and a non-zero exit; `--resume` after runs
# killed under mpirun gives the uninterrupted run's files; an untiled command under mpirun is refused. Usage: scripts/mpi-check.sh BUILD_DIR
set -euo pipefail
build=$(cd "${1:?usage: mpi-check.sh BUILD_DIR}" && pwd)
src=$(cd "$(dirname "$0")/.." && pwd)
T="$build/bin/terracl"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
# Root in CI containers: OpenMPI refuses root without these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIRUN=(mpirun --oversubscribe)
fail() { echo "mpi-check: FAIL: $*" >&2; exit 1; }

# A 203 x 157 window of the SRTM tile (geographic) with a 30 x 30 nodata lake, and a copy with one
# infinite cell that only the second tile's window of a 37-cell tiling reads (rank 1 of 2).
/usr/bin/python3 - "$src/data/dem/N44W072.hgt" <<'PY'
import sys
import numpy as np
from osgeo import gdal
ds = gdal.Open(sys.argv[1])
a = ds.ReadAsArray(300, 200, 203, 157).astype(np.float32)
gt = list(ds.GetGeoTransform()); gt[0] += 300 * gt[1]; gt[3] += 200 * gt[5]
a[40:70, 60:90] = -32768
def write(name, z):
    d = gdal.GetDriverByName("GTiff").Create(name, z.shape[1], z.shape[0], 1, gdal.GDT_Float32)
    d.SetGeoTransform(gt); d.SetProjection(ds.GetProjection())
    d.GetRasterBand(1).SetNoDataValue(-32768); d.GetRasterBand(1).WriteArray(z)
write("raw.tif", a)
b = a.copy(); b[5, 42] = np.inf
write("bad.tif", b)
# Without nodata (amplify and extract refuse it): a 90 x 75 window below the lake, and an exemplar
# for a small dictionary.
def window(name, x0, y0, w, h):
    z = ds.ReadAsArray(x0, y0, w, h).astype(np.float32)
    g = list(ds.GetGeoTransform()); g[0] += x0 * g[1]; g[3] += y0 * g[5]
    d = gdal.GetDriverByName("GTiff").Create(name, w, h, 1, gdal.GDT_Float32)
    d.SetGeoTransform(g); d.SetProjection(ds.GetProjection()); d.GetRasterBand(1).WriteArray(z)
window("amp.tif", 300, 275, 90, 75)
window("ex.tif", 700, 650, 160, 160)
PY
"$T" -q fill_depressions raw.tif -o eps.tif --epsilon  # a surface that drains, for the tiled D8
cat > p.json <<'J'
["raw.tif", {"type": "render", "file": "out/hs.tif"}, "fill_depressions", "out/f.tif",
 {"type": "read", "filename": "eps.tif"}, {"type": "drainage", "units": "cells"}, "out/d.tif",
 {"type": "read", "filename": "raw.tif"}, {"type": "crop", "x": 3, "y": 5, "width": 190},
 {"type": "render", "mode": "slope", "file": "out/s.tif"}, "out/c.tif"]
J
files="hs f d c s"
"$T" -q run p.json --tile 37 >/dev/null
mv out one
# The fill must have raised cells on both sides of a tile border (the graph phase mattered).
/usr/bin/python3 - <<'PY'
import numpy as np
from osgeo import gdal
raw = gdal.Open("raw.tif").ReadAsArray(); f = gdal.Open("one/f.tif").ReadAsArray()
up = (f > raw) & np.isfinite(f)
across = (up[:, 36] & up[:, 37]).sum() + (up[36, :] & up[37, :]).sum()
assert across > 0, "no filled depression crosses a tile border"
print(f"mpi-check: {int(up.sum())} cells filled, {int(across)} pairs across the tile borders x|y = 36|37")
PY
for n in 2 3; do
  "${MPIRUN[@]}" -n $n "$T" run p.json --tile 37 > "log$n.txt"
  grep -q "mpi: MPI (.*), $n ranks" "log$n.txt" || fail "$n ranks: no rank/device line in the report: $(cat "log$n.txt")"
  for f in $files; do cmp one/$f.tif out/$f.tif || fail "$n ranks: out/$f.tif differs from the single-process run"; done
  rm -rf out
  echo "mpi-check: $n ranks: $files identical to one process"
done

# Tiled subcommands (same command lines: the provenance records them). A render that streams just
# streams under --tile: rank 0 writes it, the other ranks wait (the pipeline above tiles its renders).
"$T" -q render raw.tif -o hs.tif --tile 40 && mv hs.tif hs1.tif
"$T" -q drainage eps.tif -o d.tif --tile 29 --units cells && mv d.tif d1.tif
"${MPIRUN[@]}" -n 3 "$T" -q render raw.tif -o hs.tif --tile 40
"${MPIRUN[@]}" -n 2 "$T" -q drainage eps.tif -o d.tif --tile 29 --units cells
cmp hs1.tif hs.tif || fail "render --tile 40 under 3 ranks differs"
cmp d1.tif d.tif || fail "drainage --tile 29 under 2 ranks differs"
echo "mpi-check: subcommands render (3 ranks) and drainage (2 ranks) identical to one process"

# Tiled amplify (x4, a 48-atom dictionary, tiles of 37 input cells: borders at 148 output cells cut
# the patch grid) under 2 and 3 ranks; then warp, resize and metrics (global stages between segments,
# metrics' sums merged on rank 0) and extract (the 2-band gradient GeoTIFF) under 2 ranks.
"$T" -q dictionary learn ex.tif -o d.tdic --atoms 48 --sparsity 1 --patch 16 --iterations 2 --constrained
cat > a.json <<'J'
["amp.tif", {"type": "amplify", "dictionary": "d.tdic", "factor": 4, "candidates": 6}, "out/amp4.tif"]
J
cat > w.json <<'J'
["raw.tif", {"type": "metrics", "json": "out/m1.json"},
 {"type": "warp", "t_srs": "EPSG:32619", "tr": [70, 70], "resampling": "cubic"}, "out/w.tif",
 {"type": "resize", "width": 300, "height": 251}, {"type": "metrics", "json": "out/m2.json"}, "out/r.tif",
 {"type": "read", "filename": "amp.tif"}, "extract", "out/g.tif",
 {"type": "read", "filename": "amp.tif"}, {"type": "amplify", "dictionary": "d.tdic", "factor": 4, "candidates": 6},
 "out/amp4.tif"]
J
for job in a w; do "$T" -q run $job.json --tile 37 >/dev/null && mv out ${job}one; done
"${MPIRUN[@]}" -n 3 "$T" -q run a.json --tile 37 >/dev/null
cmp aone/amp4.tif out/amp4.tif || fail "3 ranks: amplify --tile 37 differs from one process"
rm -rf out
"${MPIRUN[@]}" -n 2 "$T" -q run w.json --tile 37 >/dev/null
for f in amp4.tif w.tif r.tif g.tif m1.json m2.json; do
  cmp wone/$f out/$f || fail "2 ranks: amplify/warp/resize/metrics/extract: out/$f differs from the single-process run"
done
grep -q '"tiled"' out/m2.json || fail "metrics: no tiled note in out/m2.json"
rm -rf out
echo "mpi-check: amplify x4 (9 tiles) under 3 ranks; amplify, warp, resize, metrics and extract under 2 ranks: identical to one process"

# --resume under mpirun (rank 0 owns the journals and decides the finished tiles): killed (SIGKILL
# on rank 0, the test-only hook) after 12 tiles with 2 ranks, resumed with 3 ranks and killed after
# 10 more, resumed with 2 ranks: only the 13 last tiles run, and the files are cmp-equal to an
# uninterrupted single-process run. 203 x 157 with tiles of 32: 35 tiles; two writers after crops.
cat > r.json <<'J'
["raw.tif", {"type": "crop", "x": 3, "y": 2}, "r/a.tif",
 {"type": "crop", "x": 17, "y": 5, "width": 151, "height": 117}, "r/b.tif"]
J
"$T" run r.json --tile 32 --resume > r1.txt
grep -q "tiles: 35 run, 0 finished before" r1.txt || fail "resume: uninterrupted run: $(cat r1.txt)"
mkdir r1 && mv r/a.tif r/b.tif r1/
journal_tiles() { echo $(( $(wc -l < "$1") - 1 )); }
set +e
"${MPIRUN[@]}" -n 2 -x TERRACL_TEST_KILL_AFTER_TILES=12 "$T" run r.json --tile 32 --resume > rk1.txt 2>&1
rc1=$?
"${MPIRUN[@]}" -n 3 -x TERRACL_TEST_KILL_AFTER_TILES=10 "$T" run r.json --tile 32 --resume > rk2.txt 2>&1
rc2=$?
set -e
[ $rc1 -ne 0 ] && [ $rc2 -ne 0 ] || fail "resume: the killed runs exited $rc1 and $rc2"
[ ! -e r/a.tif ] && [ -e r/.a.partial.tif ] || fail "resume: the killed runs left no partial file or a final one"
[ "$(journal_tiles r/a.tif.journal)" = 22 ] || fail "resume: journal of a after two kills: $(cat r/a.tif.journal)"
"${MPIRUN[@]}" -n 2 "$T" run r.json --tile 32 --resume > r2.txt
grep -q "tiles: 13 run, 22 finished before (verified by checksum), 0 re-run" r2.txt || fail "resume: $(cat r2.txt)"
cmp r1/a.tif r/a.tif || fail "resume under 2 ranks: r/a.tif differs from the uninterrupted run"
cmp r1/b.tif r/b.tif || fail "resume under 2 ranks: r/b.tif differs from the uninterrupted run"
[ ! -e r/a.tif.journal ] && [ ! -e r/.a.partial.tif ] || fail "resume: journal or partial file left after the run"
echo "mpi-check: --resume under mpirun (killed at 12 with 2 ranks, at 22 with 3, resumed with 2): cmp-equal"

# An error on rank 1 only: every rank stops, the message is printed, no output is left.
echo '["bad.tif", "fill_depressions", "out/bad.tif"]' > bad.json
set +e
timeout 60 "${MPIRUN[@]}" -n 2 "$T" run bad.json --tile 37 > bad.txt 2>&1
rc=$?
set -e
[ $rc -ne 0 ] && [ $rc -ne 124 ] || fail "error on rank 1: exit status $rc (124: hung)"
grep -q "terracl ERROR: fill: heightfield has infinite elevations" bad.txt || fail "no message: $(cat bad.txt)"
# Open MPI's own "MPI_ABORT was invoked on rank 1" banner is sometimes lost (its help-message channel
# races the abort: "ORTE_ERROR_LOG: Data unpack would read past end of buffer ... show_help.c"), so
# either the banner or that trace of it shows the abort ran; the exit status is rank 1's own (1).
{ grep -q "MPI_ABORT was invoked on rank 1" bad.txt || grep -q "show_help.c" bad.txt; } ||
  fail "rank 1 did not stop the run: $(cat bad.txt)"
[ $rc -eq 1 ] || fail "error on rank 1: exit status $rc, expected its error's 1: $(cat bad.txt)"
[ ! -e out/bad.tif ] || fail "an output was left after the error"
echo "mpi-check: an error on rank 1 stops every rank (exit $rc) with its message"

# Untiled commands would write the same files from every rank: refused.
set +e
"${MPIRUN[@]}" -n 2 "$T" fill_depressions raw.tif -o u.tif > untiled.txt 2>&1
rc=$?
set -e
[ $rc -eq 2 ] || fail "untiled command under mpirun: exit $rc, expected 2: $(cat untiled.txt)"
grep -q "only tiled runs are distributed" untiled.txt || fail "untiled refusal message: $(cat untiled.txt)"
[ ! -e u.tif ] || fail "the refused untiled command wrote u.tif"
echo "mpi-check: untiled command under mpirun refused (exit 2)"
# Blocks compressed where they are computed (docs/scale.md, "MPI speed-up"): with tiles of 256 every
# 256^2 block of the output lies in one tile, so each rank compresses its own; 603 x 557 leaves
# partial blocks at the raster's edges. The files must not depend on the number of ranks (same
# command lines: the provenance records them).
gdal_translate -q -ot Float32 -srcwin 300 200 603 557 "$src/data/dem/N44W072.hgt" big.tif
"$T" -q fill_depressions big.tif -o big-eps.tif --epsilon
for n in 1 2 3; do
  if [ $n = 1 ]; then run=("$T"); else run=("${MPIRUN[@]}" -n $n "$T"); fi
  "${run[@]}" -q drainage big-eps.tif -o bd.tif --tile 256 --units cells && mv bd.tif bd$n.tif
  "${run[@]}" -q render big.tif -o bs.tif --mode slope --tile 256 && mv bs.tif bs$n.tif
done
for n in 2 3; do
  cmp bd1.tif bd$n.tif || fail "drainage --tile 256 under $n ranks differs"
  cmp bs1.tif bs$n.tif || fail "render slope --tile 256 under $n ranks differs"
done
echo "mpi-check: drainage --tile 256 (blocks compressed by their tiles' ranks) and render slope --tile 256 (streamed by rank 0) identical under 1, 2, 3 ranks"
echo "mpi-check: OK"
