#!/usr/bin/env bash
# Regenerates the small pictures under docs/img/ that the README shows, by running the picture
# pipelines data/pipelines/pictures-*.json (each writes its PNGs and a resolved pipeline saying how
# they were made). A pipeline that needs a stage not built yet (e.g. `render`) is skipped with a
# message; any other error stops the script.
set -euo pipefail
cd "$(dirname "$0")/.."
T=${TERRACL:-${BUILD_DIR:-build}/bin/terracl}
if [ ! -x "$T" ]; then bash scripts/build.sh; fi
made=0
for p in data/pipelines/pictures-*.json; do
  if ! msg=$("$T" run --validate "$p" 2>&1 >/dev/null); then
    if grep -q "unknown stage" <<<"$msg"; then
      echo "gen-pictures: skipping $p: $msg"
      continue
    fi
    echo "$msg" >&2
    exit 1
  fi
  "$T" -q run "$p"
  made=$((made + 1))
done
# Authoring examples: edit script -> reconstruction -> 2x block means -> shaded relief.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for name in canyon volcanic_island mountain_range dem_paste; do
  factor=2
  [ "$name" = dem_paste ] && factor=3
  "$T" -q edit --script "data/examples/$name.json" -o "$tmp/$name.tif"
  "$T" -q downsample "$tmp/$name.tif" --factor "$factor" -o "$tmp/${name}_small.tif"
  "$T" -q render "$tmp/${name}_small.tif" --mode shaded-relief -o "docs/img/edit_$name.png"
  made=$((made + 1))
done
echo "gen-pictures: made $made picture set(s); pictures are under docs/img/"
