#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Peak RSS per MPI rank of `terracl reconstruct --solver hypre` (band reads) on an N^2 gradient of
# the SRTM tile, 1 and 2 ranks, and the largest difference to the device multigrid as a fraction
# of the range (docs/scale.md, "Memory per cell of hypre itself"). Needs ~140 bytes per cell of
# free memory (8193: ~9.4 GB with 1 rank) and a -DTERRACL_MPI=ON build.
# Usage: scripts/hypre-memory.sh path/to/terracl N [workdir]
set -euo pipefail
CLI=$(realpath "$1")
N=$2
W=${3:-/tmp/hypre-memory}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mkdir -p "$W"
cd "$W"
[ -f "g$N.exr" ] || { "$CLI" -q resize "$ROOT/data/dem/N44W072.hgt" --fill-nodata --size "$N" "$N" -r cubic -o "d$N.tif" &&
  "$CLI" -q extract "d$N.tif" -o "g$N.exr"; }
[ -f "mg$N.tif" ] || "$CLI" -q reconstruct "g$N.exr" -o "mg$N.tif"
/usr/bin/time -f "1 rank: peak RSS %M KB, wall %e s" "$CLI" -q reconstruct "g$N.exr" --solver hypre -o "h1_$N.tif" \
  --report "h1_$N.json"
mpirun --oversubscribe -n 2 /usr/bin/time -f "2 ranks: peak RSS %M KB (one rank), wall %e s" "$CLI" -q reconstruct \
  "g$N.exr" --solver hypre -o "h2_$N.tif" --report "h2_$N.json"
/usr/bin/python3 - "$N" <<'PY'
import json, sys
from osgeo import gdal
import numpy as np
n = sys.argv[1]
ref = gdal.Open(f"mg{n}.tif").ReadAsArray().astype(np.float64)
rng = ref.max() - ref.min()
for r in (1, 2):
    a = gdal.Open(f"h{r}_{n}.tif").ReadAsArray().astype(np.float64)
    j = json.load(open(f"h{r}_{n}.json"))
    print(f"{r} rank(s): {j['cycles']} CG iterations, relative residual {j['final_relative_residual']:.2g}, "
          f"max |hypre - device multigrid| = {np.abs(a - ref).max() / rng:.2g} of the {rng:.0f} m range")
PY
