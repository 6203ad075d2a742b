// SPDX-License-Identifier: Apache-2.0
#pragma once
// Sinks of tiled runs other than `write`: stages that write their own file from a window of their
// input (render). Each receives, per tile, the tile's core at its level plus the halo its footprint
// needs, and writes the core into a file built window by window (docs/scale.md).
#include <functional>
#include <memory>
#include <string>
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/pipeline.hpp>
#include <vector>

namespace terracl::tile {

class TileSink {
 public:
  virtual ~TileSink() = default;
  /// `window` holds the level's cells from (wx, wy); draws the core [cx, cx + cw) x [cy, cy + ch)
  /// (level coordinates), which lies inside the window with the sink's halo around it where the
  /// level has cells. No file access: under MPI the tile's rank draws, rank 0 puts (tile_comm.hpp).
  virtual std::vector<uint8_t> draw(const Heightfield& window, int wx, int wy, int cx, int cy, int cw, int ch) = 0;
  /// Writes what draw() returned for that core into the file.
  virtual void put(const std::vector<uint8_t>& drawn, int cx, int cy, int cw, int ch) = 0;
  void write(const Heightfield& window, int wx, int wy, int cx, int cy, int cw, int ch) {
    put(draw(window, wx, wy, cx, cy, cw, ch), cx, cy, cw, ch);
  }
  /// Finishes the file and renames it to its final name.
  virtual void commit() = 0;
};

/// Why `render` with these (resolved) options cannot run tiled, or "" when it can (halo 1); in
/// tiling.cpp (core build), the sink in render_tiles.cpp (GDAL).
std::string render_tiling_limit(const json& options);

/// The tiled `render`: pictures as a tiled GeoTIFF (grey or RGB, alpha as the untiled render would
/// have it) and value rasters as a tiled float32 GeoTIFF, equal cell for cell to the untiled render
/// of the whole level. `metadata` is the level's (without terracl keys), `provenance` the stage's.
/// open = false: a sink that only draws (the ranks other than 0 of an MPI run); no file is made.
std::unique_ptr<TileSink> make_render_sink(const PipelineStage& stage, int width, int height, const Georef& level,
                                           const Metadata& metadata, const Metadata& provenance,
                                           std::function<Device&()> device, bool open = true);

/// The tiled `metrics` (metrics_tiles.cpp): the report's local statistics equal to the untiled
/// report's bit for bit, without the global figures (a note in the JSON says so). open = false:
/// a sink that only draws.
std::unique_ptr<TileSink> make_metrics_sink(const PipelineStage& stage, int width, int height, const Georef& level,
                                            const Metadata& provenance, bool open = true);

}  // namespace terracl::tile
