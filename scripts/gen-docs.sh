#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Regenerates docs/stages.md from the stage table (`terracl stages --markdown`). The test
# StagesDoc.MatchesTheStageTable fails while the checked-in file differs from the built CLI's table:
# run this after adding or changing a stage, and commit the result.
set -euo pipefail
cd "$(dirname "$0")/.."
T=${TERRACL:-${BUILD_DIR:-build}/bin/terracl}
if [ ! -x "$T" ]; then bash scripts/build.sh; fi
"$T" stages --markdown > docs/stages.md.new
mv docs/stages.md.new docs/stages.md
echo "gen-docs: wrote docs/stages.md ($(grep -c '^## ' docs/stages.md) stages)"
