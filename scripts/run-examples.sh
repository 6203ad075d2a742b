#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs every edit script in data/examples/ with `terracl edit` (each names its own base terrain)
# into out/examples/<name>.tif with a shaded-relief preview <name>.png and a report <name>.report.json.
set -euo pipefail
cd "$(dirname "$0")/.."
TERRACL=${TERRACL:-build/bin/terracl}
[ -x "$TERRACL" ] || bash scripts/build.sh
OUT=${OUT:-out/examples}
mkdir -p "$OUT"
for script in data/examples/*.json; do
  name=$(basename "$script" .json)
  echo "== $name"
  "$TERRACL" edit --script "$script" -o "$OUT/$name.tif" --preview "$OUT/$name.png" --report "$OUT/$name.report.json" "$@"
done
echo "outputs in $OUT/"
