// SPDX-License-Identifier: Apache-2.0
#pragma once
// Tiled warp / resize (warp_tiles.cpp): run by the tile engine as a stage between segments.
#include <string>
#include <terracl/pipeline.hpp>
#include <terracl/warp.hpp>

namespace terracl::tile {

bool is_warp_stage(const PipelineStage& st);
/// The stage's options as warp() takes them (resize: its size as -ts).
WarpOptions warp_options_of(const PipelineStage& st);
/// Warps the float32 GeoTIFF `in_path` (the level before the stage, georef `in_georef`) into the
/// tiled GeoTIFF `out_path` (with `metadata`) in T x T windows when `write`; returns the output's
/// header (size, georef, metadata as the untiled stage leaves them; z empty). Every rank calls it
/// for the header; one writes.
Heightfield warp_tiles(const PipelineStage& st, const std::string& in_path, const Georef& in_georef,
                       const std::string& out_path, int T, const Metadata& metadata, bool write,
                       const Progress& progress);

}  // namespace terracl::tile
