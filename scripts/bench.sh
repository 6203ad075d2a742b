#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Reconstruction benchmark: builds, then runs `terracl bench reconstruct` on 513, 1025,
# 2049 and 4097 squared grids (smooth terrain, 1 % random fixed cells, FMG + V(2,2) to relative
# residual 1e-6). Extra arguments go to every run, e.g. `scripts/bench.sh --set cycle=v` or
# `--device 1`. SIZES="513 1025" limits the sizes.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh >/dev/null
BIN=${BUILD_DIR:-build}/bin/terracl
for n in ${SIZES:-513 1025 2049 4097}; do
  reps=10
  [ "$n" -ge 2049 ] && reps=5
  [ "$n" -ge 4097 ] && reps=3
  echo "== $n x $n"
  "$BIN" bench reconstruct --size "$n" --repeats "$reps" "$@"
done
