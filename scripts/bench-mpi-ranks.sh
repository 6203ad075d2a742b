#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# 1 vs 2 MPI ranks on the same tiled jobs (docs/scale.md, "MPI speed-up"): the tiled D8
# accumulation of a 4096^2 epsilon-filled SRTM mosaic and its tiled slope render (float32 values),
# --tile 1024, wall time of the whole run and CPU seconds of each rank (/usr/bin/time per rank),
# for each terracl binary given (e.g. main's build before and this branch's after), REPEATS times.
# The 1- and 2-rank outputs of each binary must be byte-identical (cmp).
# Usage: scripts/bench-mpi-ranks.sh FILLED_4096.tif REPEATS TERRACL [TERRACL...]
# (FILLED_4096.tif: `python3 scripts/bench-tiles.py --job drainage --size 4096 --tile 1024` leaves
# it as /tmp/terracl-bench-tiles/filled-eps.tif.)
set -euo pipefail
filled=$(realpath "${1:?usage: bench-mpi-ranks.sh FILLED.tif REPEATS TERRACL...}")
repeats=${2:?repeats}
shift 2
bins=()
for b in "$@"; do bins+=("$(realpath "$b")"); done
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
echo "[\"$filled\", \"drainage\", \"$work/dr.tif\"]" > dr.json
echo "| binary | job | ranks | wall s | CPU s per rank | load avg (1 min) |"
echo "|---|---|---|---|---|---|"
for T in "${bins[@]}"; do
  bin=$T
  for job in drainage render; do
    if [ $job = drainage ]; then cmd=("$T" -q run dr.json --tile 1024); out=dr.tif
    else cmd=("$T" -q render "$filled" -o s.tif --mode slope --tile 1024); out=s.tif; fi
    for rep in $(seq "$repeats"); do
      for n in 1 2; do
        rm -f cpu.* "$out"
        load=$(cut -d' ' -f1 /proc/loadavg)
        t0=$(date +%s.%N)
        if [ $n = 1 ]; then
          /usr/bin/time -f "%U %S" -o cpu.0 "${cmd[@]}" > /dev/null
        else
          mpirun --oversubscribe -n $n bash -c '/usr/bin/time -f "%U %S" -o cpu.$OMPI_COMM_WORLD_RANK "$@"' _ "${cmd[@]}" > /dev/null
        fi
        t1=$(date +%s.%N)
        cpus=$(for f in cpu.*; do awk '{printf "%.1f", $1 + $2}' "$f"; echo -n " / "; done)
        printf "| %s | %s | %d | %.1f | %s | %s |\n" "$bin" $job $n "$(echo "$t1 - $t0" | bc)" "${cpus% / }" "$load"
        mv "$out" "$job.$n.tif"
      done
      cmp -s $job.1.tif $job.2.tif || { echo "bench-mpi-ranks: $bin $job: 2 ranks differ from 1" >&2; exit 1; }
    done
  done
done
