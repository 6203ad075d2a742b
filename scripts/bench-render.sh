#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Render benchmark: an 8192 x 4400 raster made from the bundled N44W072 tile
# (gdalwarp to UTM 19N, bilinear; nodata corners; kept in $WORK, never committed), then
# `gdaldem MODE` against `terracl render` (OpenCL device and --backend host) to a GeoTIFF
# (gdaldem's uncompressed; terracl's pictures uncompressed, its value rasters as every terracl
# GeoTIFF: DEFLATE with the floating-point predictor), each run REPEATS times (default 3) after one warm-up (kernel cache, page
# cache). Prints wall time and peak RSS (/usr/bin/time -v) of every run and the medians.
#   scripts/bench-render.sh            # hillshade
#   MODE=shaded-relief scripts/bench-render.sh
#   MODE=slope W=8193 H=8193 scripts/bench-render.sh   # value rasters: slope aspect tri tpi roughness
#   ARGS="--compress none" MODE=tri W=8193 H=8193 scripts/bench-render.sh   # uncompressed, as gdaldem
#   ORDER="terracl-device terracl-wide" scripts/bench-render.sh   # a subset
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-${BUILD_DIR:-build}/bin/terracl}
WORK=${WORK:-/tmp/terracl-bench-render}
REPEATS=${REPEATS:-3}
MODE=${MODE:-hillshade}
W=${W:-8192}
H=${H:-4400}
mkdir -p "$WORK"
BIG="$WORK/n44_${W}x${H}.tif"
if [ ! -f "$BIG" ]; then
  echo "making $BIG (gdalwarp -t_srs EPSG:32619 -ts $W $H -r bilinear)"
  gdalwarp -q -overwrite -t_srs EPSG:32619 -ts "$W" "$H" -r bilinear -ot Float32 -dstnodata -9999 \
    -co TILED=YES data/dem/N44W072.hgt "$BIG"
fi

# run NAME CMD...: one timed run; prints "NAME wall_s peak_rss_MB cpu_s" (cpu = user + system:
# steadier than wall time on a shared machine)
run() {
  local name=$1
  shift
  /usr/bin/time -v -o "$WORK/time.txt" "$@" >/dev/null
  local wall rss cpu
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' "$WORK/time.txt")
  rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$WORK/time.txt")
  cpu=$(awk -F': ' '/User time|System time/ {s += $2} END {printf "%.2f", s}' "$WORK/time.txt")
  echo "$name $wall $rss $cpu"
}

median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

declare -A CMDS
# gdaldem's name for the mode (shaded-relief and relief have no single gdaldem counterpart).
case $MODE in
  tri) GDMODE=TRI ;;
  tpi) GDMODE=TPI ;;
  *) GDMODE=$MODE ;;
esac
CMDS[gdaldem]="gdaldem $GDMODE -q $BIG $WORK/gdaldem.tif"
# ARGS: more terracl render options, e.g. ARGS="--compress none" (value rasters as gdaldem writes them).
ARGS=${ARGS:-}
CMDS[terracl-device]="$BIN -q render $BIG -o $WORK/terracl_device.tif --mode $MODE $ARGS"
CMDS[terracl-host]="$BIN -q render $BIG -o $WORK/terracl_host.tif --mode $MODE --backend host $ARGS"
# The wide launch shape (GPUs' one work-item per pixel) forced on the same device, for comparison.
CMDS[terracl-wide]="env TERRACL_LAUNCH=wide $BIN -q render $BIG -o $WORK/terracl_wide.tif --mode $MODE"
ORDER=${ORDER:-"gdaldem terracl-device terracl-host terracl-wide"}

echo "render benchmark: $W x $H cells ($BIG), mode $MODE, $REPEATS runs each (after a warm-up), $(nproc) cores"
for name in $ORDER; do ${CMDS[$name]} >/dev/null; done  # warm-up
: >"$WORK/runs.txt"
for r in $(seq "$REPEATS"); do
  for name in $ORDER; do
    # shellcheck disable=SC2086
    run "$name" ${CMDS[$name]} | tee -a "$WORK/runs.txt"
  done
done
echo "medians (wall s, peak RSS MB, CPU s):"
for name in $ORDER; do
  wall=$(awk -v n="$name" '$1 == n {print $2}' "$WORK/runs.txt" | median)
  rss=$(awk -v n="$name" '$1 == n {print $3}' "$WORK/runs.txt" | median)
  cpu=$(awk -v n="$name" '$1 == n {print $4}' "$WORK/runs.txt" | median)
  printf "  %-16s %8s s %8s MB %8s s\n" "$name" "$wall" "$rss" "$cpu"
done
