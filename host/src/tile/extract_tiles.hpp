// SPDX-License-Identifier: Apache-2.0
#pragma once
// The extract stage's tiling column (extract_tiles.cpp, docs/scale.md "Tiled extract").
#include <terracl/stage.hpp>
#include <terracl/tile.hpp>

namespace terracl::tile {

/// Exact tiling of `extract`: a local stage with a one-cell halo (forward or central differences)
/// whose gradient goes to a two-band GeoTIFF; a prepass reads the whole input level once, row
/// band by row band in raster order, for what one tile cannot know: the mean elevation (summed in
/// the untiled run's order, so the same double) and whether any cell is nodata (refused, as untiled).
StageTiling extract_tiling(const json& options);

/// The prepass result handed to each tile ("terracl:tile_prepass") -> the mean elevation.
double extract_prepass_mean(const std::string& prepass);

}  // namespace terracl::tile
