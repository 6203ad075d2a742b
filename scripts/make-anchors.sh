#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Remake the anchor fixtures of data/anchors/ (D8 pointers, watersheds, curvatures by SAGA and GRASS)
# from data/crops/presidential_utm30_192.tif.
# Needs saga_cmd (SAGA 8.5.0), grass (GRASS GIS 8.2.1), GDAL command-line tools (gdal_calc.py,
# gdal_translate) and /usr/bin/python3 with numpy + rasterio (data/anchors/README.md).
# Usage: scripts/make-anchors.sh REPO_ROOT OUT_DIR   (e.g. . data/anchors)
set -euo pipefail
REPO=$(realpath "$1"); OUT=$(realpath -m "$2"); mkdir -p "$OUT"
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT; cd "$W"
cp "$REPO/data/crops/presidential_utm30_192.tif" dem.tif     # 192x192, 30 m, EPSG:32619, no depressions
CO="-co COMPRESS=DEFLATE -a_srs EPSG:32619 -a_nodata none"
# the DEM's corners, so that the GRASS outputs (region stored to ~1e-8 m) carry its exact geotransform
ULLR=$(/usr/bin/python3 -c "import rasterio; b=rasterio.open('dem.tif').bounds; print('%r %r %r %r' % (b.left, b.top, b.right, b.bottom))")

# --- 1. SAGA Fill Sinks (Wang & Liu), MINSLOPE=0: flow directions 0..7 (0 = N, clockwise), -1 = no lower neighbour
saga_cmd -f=q ta_preprocessor 4 -ELEV dem.tif -FILLED filled.sdat -FDIR fdir.sdat -MINSLOPE 0
# -> ESRI coding: SAGA s in 0..7 -> 2^((s+6) mod 8) (0 N->64, 1 NE->128, 2 E->1, ...), -1 -> 0
gdal_calc.py --quiet -A fdir.sdat --hideNoData --type=Byte --outfile=fdir_esri_tmp.tif \
  --calc="where(A < 0, 0, 2 ** ((A + 6) % 8))"
gdal_translate -q $CO fdir_esri_tmp.tif "$OUT/saga_wl_fdir_esri.tif"

# --- 2. Basins with no ambiguous (tie / flat) cell in or around them: SAGA Upslope Area, D8, one run per point
i=0
for XY in "313723.586 4909362.008" "311593.586 4909032.008" "312043.586 4905672.008"; do
  i=$((i+1)); set -- $XY
  saga_cmd -f=q ta_hydrology 4 -ELEVATION dem.tif -TARGET_PT_X $1 -TARGET_PT_Y $2 -METHOD 0 -AREA up$i.sdat
done
gdal_calc.py --quiet -A up1.sdat -B up2.sdat -C up3.sdat --hideNoData --type=Byte --outfile=bx_tmp.tif \
  --calc="1*(A > 0) + 2*(B > 0) + 3*(C > 0)"
gdal_translate -q $CO bx_tmp.tif "$OUT/saga_basins_exact.tif"

# --- 3. GRASS: r.fill.dir directions (format=grass, degrees CCW from E -> /45 = r.watershed's 1..8 coding),
#        r.watershed -s (SFD) drainage and r.water.outlet basins of three main-stem pour points
cat > grass_job.sh <<'GEOF'
set -e
r.in.gdal -o input=dem.tif output=dem --quiet
g.region raster=dem
r.fill.dir input=dem output=fd_filled direction=fd_deg format=grass --quiet
r.mapcalc "fd_code = int(fd_deg / 45)" --quiet
r.out.gdal -c -m -f input=fd_code output=grass_filldir_drainage.tif format=GTiff type=Byte createopt=COMPRESS=DEFLATE --quiet
r.watershed -s elevation=dem drainage=ws_dir --quiet
r.water.outlet input=ws_dir output=m1 coordinates=311143.586,4910772.008 --quiet
r.water.outlet input=ws_dir output=m2 coordinates=311083.586,4905222.008 --quiet
r.water.outlet input=ws_dir output=m3 coordinates=314053.586,4910772.008 --quiet
r.mapcalc "main = if(isnull(m1), 0, 1) + if(isnull(m2), 0, 2) + if(isnull(m3), 0, 3)" --quiet
r.out.gdal -c -m -f input=main output=grass_basins_main.tif format=GTiff type=Byte createopt=COMPRESS=DEFLATE --quiet
GEOF
# --- 3b. GRASS r.slope.aspect profile and tangential curvature of the 64 x 64 window at column 64,
#         row 64 (its border is null: the 3 x 3 window leaves the crop there)
gdal_translate -q -srcwin 64 64 64 64 dem.tif win.tif
cat >> grass_job.sh <<'GEOF'
r.in.gdal -o input=win.tif output=win --quiet
g.region raster=win
r.slope.aspect elevation=win pcurvature=pc tcurvature=tc precision=DCELL --quiet
r.out.gdal -c -m -f input=pc output=grass_pcurvature_64.tif format=GTiff type=Float32 createopt=COMPRESS=DEFLATE --quiet
r.out.gdal -c -m -f input=tc output=grass_tcurvature_64.tif format=GTiff type=Float32 createopt=COMPRESS=DEFLATE --quiet
GEOF
grass --tmp-location EPSG:32619 --exec bash grass_job.sh
WULLR=$(/usr/bin/python3 -c "import rasterio; b=rasterio.open('win.tif').bounds; print('%r %r %r %r' % (b.left, b.top, b.right, b.bottom))")
for k in pcurvature tcurvature; do
  gdal_translate -q -co COMPRESS=DEFLATE -a_srs EPSG:32619 -a_ullr $WULLR grass_${k}_64.tif "$OUT/grass_${k}_64.tif"
done
gdal_translate -q $CO -a_ullr $ULLR grass_filldir_drainage.tif "$OUT/grass_filldir_drainage.tif"
gdal_translate -q $CO -a_ullr $ULLR grass_basins_main.tif "$OUT/grass_basins_main.tif"

# --- 4. Mask of the cells where every correct D8 must agree (see COMMANDS.md): 1 = the cell has exactly one
#        steepest strictly-lower in-grid neighbour on the filled surface (SAGA's filled.sdat), 0 otherwise
/usr/bin/python3 - filled.sdat d8_unambiguous_tmp.tif <<'PEOF'
import sys, numpy as np, rasterio
with rasterio.open(sys.argv[1]) as d: z = d.read(1).astype(np.float64); prof = d.profile
H, W = z.shape
zp = np.full((H + 2, W + 2), np.nan); zp[1:-1, 1:-1] = z
g = []
for dr in (-1, 0, 1):
    for dc in (-1, 0, 1):
        if dr or dc:
            s = (z - zp[1 + dr:1 + dr + H, 1 + dc:1 + dc + W]) / (30.0 * np.hypot(dr, dc))
            g.append(np.where(np.isnan(s), -np.inf, s))
g = np.array(g); best = g.max(0)
mask = ((best > 0) & ((g == best).sum(0) == 1)).astype(np.uint8)
prof.update(driver="GTiff", dtype="uint8", nodata=None, count=1)
with rasterio.open(sys.argv[2], "w", **prof) as d: d.write(mask, 1)
PEOF
gdal_translate -q $CO d8_unambiguous_tmp.tif "$OUT/d8_unambiguous.tif"
ls -l "$OUT"
