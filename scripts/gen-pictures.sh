#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
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
  # Beside it a perspective view of the full-resolution result (1024 x 640), each camera chosen so
  # that the landform reads (docs/authoring.md says which paper figure each one stands next to).
  case "$name" in
    canyon) view="--view-azimuth 140 --view-elevation 32 --view-zoom 1.3 --azimuth 250 --altitude 60" ;;
    volcanic_island) view="--view-azimuth 200 --view-elevation 30 --view-zoom 1.15 --azimuth 250 --altitude 35" ;;
    mountain_range) view="--view-azimuth 200 --view-elevation 26 --view-target 520,560 --view-zoom 1.5 --azimuth 150 --altitude 35" ;;
    cliff) view="--view-azimuth 100 --view-elevation 25 --view-zoom 1.4 --azimuth 100 --altitude 35" ;;
    river_valley) view="--view-azimuth 80 --view-elevation 35 --view-target 450,300 --view-zoom 2.6 --z-factor 1.5 --azimuth 160 --altitude 35" ;;
    dem_paste) view="--view-azimuth 100 --view-elevation 40 --view-target 620,560 --view-zoom 2.6 --z-factor 2 --azimuth 190 --altitude 40" ;;
  esac
  # shellcheck disable=SC2086
  "$T" -q render "$tmp/$name.tif" --mode perspective $view -o "docs/img/edit_${name}_3d.png"
  made=$((made + 1))
done
echo "gen-pictures: made $made picture set(s); pictures are under docs/img/"
