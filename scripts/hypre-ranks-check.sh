#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# ctest hypre_two_ranks (label mpi): `terracl reconstruct --solver hypre` under
# `mpirun --oversubscribe -n 2` and `-n 3` (each rank reads only its band of the gradient file)
# equals the single-process solve (to 1e-7 of the range: hypre's dot products sum in another
# order), on a DEM crop with hard constraints; ranks other than 0 write nothing. The other band
# reads too (3 ranks): central gradients with --initial, --border dirichlet, --fixed-mask /
# --fixed-elevation and a constraint file whose omitted z and frozen polygon take the start's
# values in other ranks' bands (--divergence: tests/hypre, Hypre.BandReadsOfEveryInput...).
# Usage: hypre-ranks-check.sh path/to/terracl [mpirun]
set -euo pipefail
CLI=$1
MPIRUN=${2:-mpirun}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# CI containers run as root; OpenMPI refuses that without these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$CLI" crop "$ROOT/data/dem/frontrange_srtm3_758.asc" --x 200 --y 300 --width 257 --height 203 -o "$tmp/dem.tif"
"$CLI" extract "$tmp/dem.tif" -o "$tmp/g.exr"
cat > "$tmp/c.json" <<'JSON'
{"units": "pixels",
 "points": [{"x": 30, "y": 40, "z": 2600}, {"x": 200, "y": 150, "z": 2300}],
 "polylines": [{"points": [[60, 100, 2400], [180, 100, 2500]], "width": 1}]}
JSON
opts=(--solver hypre --tolerance 1e-10 --max-cycles 300 --constraints "$tmp/c.json")
"$CLI" reconstruct "$tmp/g.exr" "${opts[@]}" -o "$tmp/one.tif" --report "$tmp/one.json"
"$MPIRUN" --oversubscribe -n 2 "$CLI" reconstruct "$tmp/g.exr" "${opts[@]}" -o "$tmp/two.tif" --report "$tmp/two.json"
"$MPIRUN" --oversubscribe -n 3 "$CLI" reconstruct "$tmp/g.exr" "${opts[@]}" -o "$tmp/three.tif" --report "$tmp/three.json"

"$CLI" extract "$tmp/dem.tif" --central -o "$tmp/gc.exr"
/usr/bin/python3 - "$tmp" <<'PY'
import sys
from osgeo import gdal
import numpy as np
t = sys.argv[1]
d = gdal.Open(f"{t}/dem.tif")
z = d.ReadAsArray().astype(np.float64)
yy, xx = np.mgrid[0:z.shape[0], 0:z.shape[1]]
def save(name, a):
    o = gdal.GetDriverByName("GTiff").Create(f"{t}/{name}", z.shape[1], z.shape[0], 1, gdal.GDT_Float32)
    o.SetGeoTransform(d.GetGeoTransform())
    o.SetProjection(d.GetProjection())
    o.GetRasterBand(1).WriteArray(a.astype(np.float32))
    o = None
save("mask.tif", ((xx * 5 + yy * 3) % 97 == 0).astype(np.float32))
save("elev.tif", z + 40)
save("start.tif", z + 30 * np.sin(xx / 9.0))
PY
cat > "$tmp/c2.json" <<'JSON'
{"units": "pixels", "points": [[30, 190], {"x": 200, "y": 20, "z": 2300}],
 "polylines": [{"points": [[20, 10], [230, 190, 2500]], "width": 2}],
 "polygons": [{"points": [[100, 80], [160, 90], [130, 140]]}]}
JSON
copts=(--solver hypre --tolerance 1e-10 --max-cycles 300 --initial "$tmp/start.tif" --border dirichlet
       --fixed-mask "$tmp/mask.tif" --fixed-elevation "$tmp/elev.tif" --constraints "$tmp/c2.json")
"$CLI" reconstruct "$tmp/gc.exr" "${copts[@]}" -o "$tmp/c_one.tif" --report "$tmp/c_one.json"
"$MPIRUN" --oversubscribe -n 3 "$CLI" reconstruct "$tmp/gc.exr" "${copts[@]}" -o "$tmp/c_three.tif" --report "$tmp/c_three.json"

/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
from osgeo import gdal
import numpy as np
t = sys.argv[1]
one = gdal.Open(f"{t}/one.tif").ReadAsArray().astype(np.float64)
two = gdal.Open(f"{t}/two.tif").ReadAsArray().astype(np.float64)
three = gdal.Open(f"{t}/three.tif").ReadAsArray().astype(np.float64)
r1, r2, r3 = (json.load(open(f"{t}/{n}.json")) for n in ("one", "two", "three"))
for a, b, n in (("c_one", "c_three", 3),):
    x = gdal.Open(f"{t}/{a}.tif").ReadAsArray().astype(np.float64)
    y = gdal.Open(f"{t}/{b}.tif").ReadAsArray().astype(np.float64)
    ra, rb = (json.load(open(f"{t}/{m}.json")) for m in (a, b))
    assert ra["converged"] and rb["converged"] and rb["mpi_ranks"] == n, (ra, rb)
    assert "input read by bands of rows" in rb["device"] and ra["hard_cells"] == rb["hard_cells"] > 0, (ra, rb)
    diff, rng = np.abs(x - y).max(), x.max() - x.min()
    print(f"{a} vs {b}: max difference {diff:.3e} m of a {rng:.1f} m range, {rb['hard_cells']} hard cells")
    assert rng > 10 and np.isfinite(y).all() and diff <= 1e-7 * rng, diff
for r, n in ((r1, 1), (r2, 2), (r3, 3)):
    assert r["solver"] == "hypre" and r["mpi_ranks"] == n and r["converged"], r
    assert "input read by bands of rows" in r["device"], r  # each rank read only its rows
rng = one.max() - one.min()
for other, r, n in ((two, r2, 2), (three, r3, 3)):
    diff = np.abs(one - other).max()
    print(f"1 rank vs {n} ranks: max difference {diff:.3e} m of a {rng:.1f} m range "
          f"({r1['cycles']} / {r['cycles']} CG iterations)")
    assert rng > 100 and np.isfinite(other).all()
    assert diff <= 1e-7 * rng, diff
PY
# Rank 1 must not have written anything of its own.
test "$(ls "$tmp" | sort | tr '\n' ' ')" = "c.json c2.json c_one.json c_one.tif c_three.json c_three.tif dem.tif elev.tif g.exr gc.exr mask.tif one.json one.tif start.tif three.json three.tif two.json two.tif "
echo "hypre_two_ranks: OK"
