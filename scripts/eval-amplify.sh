#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Evaluation of amplification (issues 6 and 16) against bicubic upsampling.
# For each DEM in data/dem/: west half = exemplar, east half = truth, input = block means of the
# truth (x4 and x16); prints, for --mode detail and --mode faithful, RMSE, PSNR, HF energy ratio above
# the input's Nyquist, roughness ratio, mean-slope ratio, LR consistency, the periodic peaks of the
# squared curvature at the patch spacing and the block size, D8 river agreement with the truth (see
# docs/amplify.md) and the calibrated gains, FLANN recall for x4, and with --bench the timings of x4
# of a 1201^2 DEM and x256 of 32^2 -> 8192^2. Detail mode's pk S / pk f are read from the curvature
# spectra averaged over 3 seeds (--seed S, S+1, S+2; TRACE_SEEDS=1: one seed, as before issue 16
# session 8); the other columns are seed S's. The detail blend's correlation is anisotropic by
# default; pass --no-detail-anisotropy for the single-rho figures.
#   scripts/eval-amplify.sh [--bench] [extra `terracl dictionary evaluate` options]
set -euo pipefail
cd "$(dirname "$0")/.."
BENCH=0
if [[ "${1:-}" == "--bench" ]]; then BENCH=1; shift; fi
[[ -x build/bin/terracl ]] || JOBS=${JOBS:-2} bash scripts/build.sh
T=build/bin/terracl
header=--header
for dem in data/dem/*.hgt data/dem/*.asc; do
  for f in 4 16; do
    recall=()
    [[ $f == 4 ]] && recall=(--recall 2000)
    $T dictionary evaluate "$dem" --factor $f $header --trace-seeds "${TRACE_SEEDS:-3}" "${recall[@]}" "$@"
    header=
    $T dictionary evaluate "$dem" --factor $f --mode faithful "$@"
  done
done
if [[ $BENCH == 1 ]]; then
  echo
  # complete dictionary (every exemplar patch, FLANN) and a learned one (256 constrained atoms, exact scan)
  learned=(--set method=constrained --set atoms=256 --set max_patches=20000)
  $T bench amplify --size 1201 --repeats 3 --set factor=4
  $T bench amplify --size 1201 --repeats 3 --set factor=4 "${learned[@]}"
  $T bench amplify --size 32 --repeats 3 --set factor=256
  $T bench amplify --size 32 --repeats 3 --set factor=256 "${learned[@]}"
fi
