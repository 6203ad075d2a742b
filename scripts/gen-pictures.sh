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
# Authoring examples: edit script -> reconstruction -> shaded relief with the hypsometric ramp
# (metres). The 1025^2 gallery is shown at 513 px (2x block means), the 758^2 DEM examples at full size.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for name in canyon volcanic_island mountain_range cliff river_valley dem_paste; do
  factor=2
  case "$name" in dem_paste | river_valley) factor=1 ;; esac
  "$T" -q edit --script "data/examples/$name.json" -o "$tmp/$name.tif"
  src="$tmp/$name.tif"
  if [ "$factor" != 1 ]; then
    "$T" -q downsample "$tmp/$name.tif" --factor "$factor" -o "$tmp/${name}_small.tif"
    src="$tmp/${name}_small.tif"
  fi
  "$T" -q render "$src" --mode shaded-relief -o "docs/img/edit_$name.png"
  made=$((made + 1))
done
echo "gen-pictures: made $made picture set(s); pictures are under docs/img/"
