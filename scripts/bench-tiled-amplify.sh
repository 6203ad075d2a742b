#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Figure of tiled amplify (docs/scale.md "Tiled amplify"): x4 with --tile 2048 of
# 2048^2, 4096^2 and 8192^2 inputs (the SRTM tile resized), wall/CPU/peak RSS; outputs deleted after.
# Usage: scripts/bench-tiled-amplify.sh [WORKDIR] (default /tmp/terracl-tiled-amplify; needs ~2.5 GB free)
set -u
T=$(cd "$(dirname "$0")/.." && pwd)/build/bin/terracl; SRC=$(cd "$(dirname "$0")/.." && pwd)
W=${1:-/tmp/terracl-tiled-amplify}; mkdir -p "$W"; cd "$W"
echo "start $(date -u +%T)"
[ -f d.tdic ] || /usr/bin/time -f "learn: %e s wall %U s user" $T dictionary learn $SRC/data/dem/N44W072.hgt -o d.tdic --atoms 256 --constrained 2>&1 | tail -2
for n in 2048 4096 8192; do
  [ -f in$n.tif ] || gdal_translate -q -outsize $n $n -r bilinear -co TILED=YES $SRC/data/dem/N44W072.hgt in$n.tif
  printf '["in%s.tif", {"type": "amplify", "dictionary": "d.tdic", "factor": 4}, "out%s.tif"]\n' $n $n > p$n.json
  echo "== $n -> $((4*n)) $(date -u +%T)"
  /usr/bin/time -f "x4 $n: %e s wall, %U s user, %S s sys, peak RSS %M KiB" $T run p$n.json --tile 2048 > run$n.log 2>&1 &
  pid=$!
  while kill -0 $pid 2>/dev/null; do
    c=$(pgrep -P $pid terracl | head -1); [ -n "$c" ] && grep VmHWM /proc/$c/status 2>/dev/null | sed "s/^/$(date -u +%T) $n /" >> hwm$n.log
    tail -c 200 run$n.log | tr '\r' '\n' | grep tile | tail -1 >> prog$n.log
    sleep 15
  done
  wait $pid; tail -5 run$n.log
  ls -la out$n.tif 2>/dev/null; gdalinfo out$n.tif 2>/dev/null | grep -E "Size is|Block=|COMPRESSION" | head -3
  rm -f out$n.tif
done
echo "end $(date -u +%T)"
