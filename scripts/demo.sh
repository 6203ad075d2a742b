#!/usr/bin/env bash
# The main job: installs what is missing, builds Release, runs the demo on the bundled SRTM data and
# prints what it wrote under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
T=build/bin/terracl
mkdir -p out
$T devices
$T info data/dem/N44W072.hgt
$T convert data/dem/N44W072.hgt out/N44W072.tif
$T convert data/dem/N44W072.hgt out/N44W072.png
$T convert data/dem/frontrange_srtm3_758.asc out/frontrange.exr
echo
echo "demo.sh wrote:"
ls -l out/
