// SPDX-License-Identifier: Apache-2.0
#pragma once
// The amplify stage's tiling column (amplify_tiles.cpp, docs/scale.md "Tiled amplify").
#include <terracl/stage.hpp>
#include <terracl/tile.hpp>

namespace terracl::tile {

/// Exact tiling of a dictionary amplify (detail mode): a local stage that multiplies the grid by its
/// factor, with amplify_halo input cells of halo and a prepass that measures the detail blend's
/// correlations on the whole input; refusals (exemplars, style masks, faithful mode) say why.
StageTiling amplify_tiling(const json& options);

}  // namespace terracl::tile
