#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# terracl against the tools a user would otherwise run (issue #34's anchors), one row per task:
# each pair of whole commands runs A B A B (REPEATS pairs, default 2, after one warm-up pair), and
# the row prints the medians of wall time and peak RSS of both and their ratios, as a Markdown
# table, with the load average before and after. Inputs are made from the bundled N44W072 tile in
# $WORK (never committed). Missing anchors are installed from Debian (gdal-bin, grass-core, saga)
# when apt-get can run; a row whose anchor is missing prints "not installed".
#   scripts/bench-anchors.sh                 # every row
#   scripts/bench-anchors.sh amplify fill    # some rows
# Rows: startup amplify amplify-exemplar amplify-x16 hillshade slope aspect tri tpi roughness
#       fill d8 dinf reconstruct
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=$(realpath "${BIN:-${BUILD_DIR:-build}/bin/terracl}")
WORK=${WORK:-/tmp/terracl-bench-anchors}
REPEATS=${REPEATS:-2}
DEM=$(realpath data/dem/N44W072.hgt)
ROWS=${*:-"startup amplify amplify-exemplar amplify-x16 hillshade slope aspect tri tpi roughness fill d8 dinf reconstruct"}
mkdir -p "$WORK"
cd "$WORK"

need() {  # need COMMAND PACKAGE: install PACKAGE when COMMAND is missing and apt-get can run
  command -v "$1" >/dev/null && return 0
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$2" >/dev/null 2>&1 || true
  fi
  command -v "$1" >/dev/null
}
need gdalwarp gdal-bin || { echo "gdal-bin is needed" >&2; exit 1; }

# Inputs.
BIG=$WORK/big8193.tif  # 8193^2 float32, tiled DEFLATE (as docs/performance.md)
[ -f "$BIG" ] || gdalwarp -q -r cubic -ts 8193 8193 -ot Float32 -co TILED=YES -co COMPRESS=DEFLATE "$DEM" "$BIG"
DICT=$WORK/frontrange.tdic  # a factor-4 dictionary learned from the other bundled DEM
[ -f "$DICT" ] || "$BIN" -q dictionary learn "$OLDPWD/data/dem/frontrange_srtm3_758.asc" -o "$DICT"
EXEMPLAR=$WORK/n44_utm30.tif  # 30 m cells: the exemplar of a 120 m input
[ -f "$EXEMPLAR" ] || gdalwarp -q -r cubic -t_srs EPSG:32619 -tr 30 30 -te 290000 4920000 320000 4950000 "$DEM" "$EXEMPLAR"
N44NPY=$WORK/n44.npy  # the tile's cells without georeferencing, read as 120 m cells
[ -f "$N44NPY" ] || "$BIN" -q convert "$DEM" "$N44NPY"
SMALL=$WORK/small.tif  # 128 x 96 GeoTIFF for start-up
[ -f "$SMALL" ] || gdal_translate -q -srcwin 0 0 128 96 -ot Float32 "$DEM" "$SMALL"

# One timed run: prints "wall_s peak_rss_MiB".
run() {
  /usr/bin/time -f "%e %M" -o "$WORK/time.txt" bash -c "$1" >/dev/null 2>&1 || { echo "failed: $1" >&2; echo "nan nan"; return; }
  awk '{printf "%s %.0f\n", $1, $2 / 1024}' "$WORK/time.txt"
}
median() { sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) cores"
echo
echo "| task | terracl | anchor | time ratio | terracl MiB | anchor MiB | memory ratio | anchor command |"
echo "|---|---|---|---|---|---|---|---|"
row() {  # row NAME TERRACL_CMD ANCHOR_CMD ANCHOR_LABEL
  local name=$1 a=$2 b=$3 label=$4 ta=() tb=() ma=() mb=()
  run "$a" >/dev/null
  run "$b" >/dev/null
  for _ in $(seq "$REPEATS"); do
    read -r t m < <(run "$a"); ta+=("$t"); ma+=("$m")
    read -r t m < <(run "$b"); tb+=("$t"); mb+=("$m")
  done
  local xa xb ya yb
  xa=$(printf '%s\n' "${ta[@]}" | median); xb=$(printf '%s\n' "${tb[@]}" | median)
  ya=$(printf '%s\n' "${ma[@]}" | median); yb=$(printf '%s\n' "${mb[@]}" | median)
  awk -v n="$name" -v xa="$xa" -v xb="$xb" -v ya="$ya" -v yb="$yb" -v l="$label" \
    'BEGIN {printf "| %s | %.2f s | %.2f s | %.2fx | %d | %d | %.2fx | %s |\n", n, xa, xb, xa / xb, ya, yb, ya / yb, l}'
}
missing() { echo "| $1 | | | | | | | $2 not installed |"; }

GRASS_RUN() {  # GRASS_RUN "module commands": import BIG as dem, run, in a temporary location
  echo "grass --tmp-location $BIG --exec bash -c 'r.in.gdal -o input=$BIG output=dem >/dev/null 2>&1 && g.region raster=dem && $1'"
}

for r in $ROWS; do
  case $r in
    startup)
      row "info of a 128x96 GeoTIFF" "$BIN info $SMALL" "gdalinfo -stats $SMALL" "gdalinfo -stats" ;;
    amplify)
      row "amplify x4 1201^2, dictionary" "$BIN -q amplify $DEM --dictionary $DICT -o a4.tif" \
        "gdalwarp -q -overwrite -r cubic -ts 4804 4804 $DEM w4.tif" "gdalwarp -r cubic (Int16 out)"
      row "same, uncompressed Float32 out" "$BIN -q amplify $DEM --dictionary $DICT -o a4n.tif --co COMPRESS=NONE" \
        "gdalwarp -q -overwrite -r cubic -ot Float32 -ts 4804 4804 $DEM w4f.tif" "gdalwarp -r cubic -ot Float32" ;;
    amplify-exemplar)
      row "amplify x4 1201^2, exemplar learned in the run" \
        "$BIN -q amplify $N44NPY --cell-size 120 --exemplar $EXEMPLAR -o e4.tif" \
        "gdalwarp -q -overwrite -r cubic -ts 4804 4804 $DEM w4.tif" "gdalwarp -r cubic (Int16 out)" ;;
    amplify-x16)
      row "amplify x16 to 19216^2, dictionary" "$BIN -q amplify $DEM --dictionary $DICT --factor 16 -o a16.tif" \
        "gdalwarp -q -overwrite -r cubic -ot Float32 -ts 19216 19216 $DEM w16.tif" "gdalwarp -r cubic -ot Float32"
      rm -f a16.tif w16.tif ;;
    hillshade | slope | aspect | tri | tpi | roughness)
      gd=$r; [ "$r" = tri ] && gd=TRI; [ "$r" = tpi ] && gd=TPI
      row "$r 8193^2" "$BIN -q render $BIG --mode $r -o r_$r.tif" "gdaldem $gd -q $BIG g_$r.tif" "gdaldem $gd" ;;
    fill)
      if need grass grass-core; then
        row "fill 8193^2" "$BIN -q fill_depressions $BIG -o fill.tif" \
          "$(GRASS_RUN "r.fill.dir input=dem output=filled direction=dir >/dev/null 2>&1 && r.out.gdal -f --overwrite input=filled output=$WORK/grass_fill.tif >/dev/null 2>&1")" "GRASS r.fill.dir"
      else missing "fill 8193^2" "GRASS"; fi
      if need saga_cmd saga; then
        row "fill 8193^2" "$BIN -q fill_depressions $BIG -o fill.tif" \
          "saga_cmd io_gdal 0 -FILES $BIG -GRIDS big.sgrd >/dev/null && saga_cmd ta_preprocessor 4 -ELEV big.sgrd -FILLED saga_fill.sgrd >/dev/null" "SAGA Fill Sinks (Wang & Liu)"
      else missing "fill 8193^2" "SAGA"; fi ;;
    d8)
      if need grass grass-core; then
        row "D8 accumulation 8193^2" "$BIN -q drainage $BIG -o d8.tif" \
          "$(GRASS_RUN "r.watershed -s elevation=dem accumulation=acc >/dev/null 2>&1 && r.out.gdal -f --overwrite input=acc output=$WORK/grass_acc.tif >/dev/null 2>&1")" "GRASS r.watershed -s"
      else missing "D8 accumulation 8193^2" "GRASS"; fi ;;
    dinf)
      if need saga_cmd saga; then
        row "D-inf accumulation 8193^2" "$BIN -q drainage $BIG --method dinf -o dinf.tif" \
          "saga_cmd io_gdal 0 -FILES $BIG -GRIDS big.sgrd >/dev/null && saga_cmd ta_preprocessor 4 -ELEV big.sgrd -FILLED saga_fill.sgrd >/dev/null && saga_cmd ta_hydrology 0 -ELEVATION saga_fill.sgrd -FLOW saga_dinf.sgrd -METHOD 3 >/dev/null" "SAGA fill + Flow Accumulation (DInf)"
      else missing "D-inf accumulation 8193^2" "SAGA"; fi ;;
    reconstruct)
      # In-process solves (file I/O excluded), both to <= 1e-6 of the range against a float64 solve.
      for n in 1025 4097; do
        a=$("$BIN" bench reconstruct --size $n --repeats 3 --set refine=auto)
        b=$("$BIN" bench reconstruct --size $n --repeats 3 --set solver=hypre --set tolerance=1e-7)
        ta=$(awk '/^median_ms/ {print $2}' <<<"$a"); tb=$(awk '/^median_ms/ {print $2}' <<<"$b")
        ea=$(awk '/^max_error_m/ {gsub(/\(/, "", $3); print $3}' <<<"$a"); eb=$(awk '/^max_error_m/ {gsub(/\(/, "", $3); print $3}' <<<"$b")
        awk -v n=$n -v ta="$ta" -v tb="$tb" -v ea="$ea" -v eb="$eb" \
          'BEGIN {printf "| reconstruct %d^2 (bench, refine auto; error %s of the range) | %.1f ms | %.1f ms | %.2fx | | | | hypre PFMG-CG, tolerance 1e-7 (error %s) |\n", n, ea, ta, tb, ta / tb, eb}'
      done ;;
    *) echo "unknown row $r" >&2; exit 2 ;;
  esac
done
echo
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
