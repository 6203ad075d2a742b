#!/usr/bin/env bash
# ctest hypre_two_ranks (label mpi): `terracl reconstruct --solver hypre` under
# `mpirun --oversubscribe -n 2` equals the single-process solve (to 1e-7 of the range: the two
# runs sum in different orders), on a DEM crop with hard constraints; rank 1 writes nothing.
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

/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
from osgeo import gdal
import numpy as np
t = sys.argv[1]
one = gdal.Open(f"{t}/one.tif").ReadAsArray().astype(np.float64)
two = gdal.Open(f"{t}/two.tif").ReadAsArray().astype(np.float64)
r1, r2 = json.load(open(f"{t}/one.json")), json.load(open(f"{t}/two.json"))
assert r1["solver"] == "hypre" and r1["mpi_ranks"] == 1, r1
assert r2["solver"] == "hypre" and r2["mpi_ranks"] == 2, r2
assert r1["converged"] and r2["converged"], (r1, r2)
rng = one.max() - one.min()
diff = np.abs(one - two).max()
print(f"1 rank vs 2 ranks: max difference {diff:.3e} m of a {rng:.1f} m range "
      f"({r1['cycles']} / {r2['cycles']} CG iterations)")
assert rng > 100 and np.isfinite(two).all()
assert diff <= 1e-7 * rng, diff
PY
# Rank 1 must not have written anything of its own.
test "$(ls "$tmp" | sort | tr '\n' ' ')" = "c.json dem.tif g.exr one.json one.tif two.json two.tif "
echo "hypre_two_ranks: OK"
