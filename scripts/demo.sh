#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job (the README's first command): installs what is missing, builds Release, runs the
# pipelines below on the bundled SRTM data and prints what each wrote under out/ with per-stage
# times. A pipeline that needs a stage not built yet is skipped with a message.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# The same build as scripts/test.sh (MPI on), so running both does not rebuild everything.
TERRACL_MPI=${TERRACL_MPI:-ON} bash scripts/build.sh
T=build/bin/terracl

# The main job first, then the authoring examples (edit script -> reconstruct -> render) as they
# land: one line per pipeline.
PIPELINES=(
  data/pipelines/demo.json
)

# Compile every kernel once now (PoCL caches them), so no stage below pays a first-use compile.
$T devices --warm
status=0
for p in "${PIPELINES[@]}"; do
  echo
  echo "== $p"
  if ! msg=$($T run --validate "$p" 2>&1 >/dev/null); then
    if grep -q "unknown stage" <<<"$msg"; then
      echo "demo: skipping $p (a stage it needs is not built yet): $msg"
      continue
    fi
    echo "$msg" >&2
    status=1
    continue
  fi
  $T run "$p" || status=1
done

# The authoring examples: edit script -> multigrid reconstruction -> shaded-relief preview.
echo
echo "== authoring examples (data/examples/*.json)"
TERRACL=$T bash scripts/run-examples.sh || status=1

echo
echo "demo.sh wrote under out/:"
find out -type f | sort | while read -r f; do
  printf "  %10s  %s\n" "$(du -h "$f" | cut -f1)" "$f"
done
exit $status
