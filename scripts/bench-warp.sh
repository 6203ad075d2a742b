#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# terracl warp / resize against the gdalwarp program on the bundled SRTM tile (docs/io.md):
# wall time of each (best of 3) and the largest difference of their outputs.
set -euo pipefail
cd "$(dirname "$0")/.."
T=${TERRACL:-${BUILD_DIR:-build}/bin/terracl}
D=$(mktemp -d)
trap 'rm -rf "$D"' EXIT
IN=data/dem/N44W072.hgt
"$T" convert "$IN" "$D/in.tif" -q
best() {  # best wall time of 3 runs of "$@"
  local b=1e9
  for _ in 1 2 3; do
    local s e
    s=$(date +%s.%N); "$@" >/dev/null 2>&1; e=$(date +%s.%N)
    b=$(/usr/bin/python3 -c "print(min($b, $e - $s))")
  done
  printf "%.3f" "$b"
}
for r in bilinear cubic average; do
  a=$(best "$T" -q warp "$D/in.tif" -o "$D/t_$r.tif" --t-srs EPSG:32619 --tr 30 30 --resampling "$r")
  g=$(best gdalwarp -q -overwrite -t_srs EPSG:32619 -tr 30 30 -r "$r" -ot Float32 "$D/in.tif" "$D/g_$r.tif")
  diff=$(/usr/bin/python3 - "$D/t_$r.tif" "$D/g_$r.tif" <<'PY'
import sys
import numpy as np
from osgeo import gdal
a, b = (gdal.Open(f).ReadAsArray().astype(np.float64) for f in sys.argv[1:3])
m = np.isfinite(a) & (a > -30000)
print(a.shape[1], "x", a.shape[0], "max |diff|", float(np.nanmax(np.abs(a[m] - b[m]))))
PY
)
  echo "warp 1201^2 SRTM3 -> EPSG:32619 30 m $r: terracl ${a} s, gdalwarp ${g} s; $diff"
done
a=$(best "$T" -q resize "$D/in.tif" -o "$D/u.r16" --preset unreal-1009)
echo "resize 1201^2 -> unreal-1009 (.r16 + sidecar): terracl ${a} s"
