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

namespace terracl::tile {

class TileSink {
 public:
  virtual ~TileSink() = default;
  /// `window` holds the level's cells from (wx, wy); writes the core [cx, cx + cw) x [cy, cy + ch)
  /// (level coordinates), which lies inside the window with the sink's halo around it where the
  /// level has cells.
  virtual void write(const Heightfield& window, int wx, int wy, int cx, int cy, int cw, int ch) = 0;
  /// Finishes the file and renames it to its final name.
  virtual void commit() = 0;
};

/// Why `render` with these (resolved) options cannot run tiled, or "" when it can (halo 1); in
/// tiling.cpp (core build), the sink in render_tiles.cpp (GDAL).
std::string render_tiling_limit(const json& options);

/// The tiled `render`: pictures as a tiled GeoTIFF (grey or RGB, alpha as the untiled render would
/// have it) and value rasters as a tiled float32 GeoTIFF, equal cell for cell to the untiled render
/// of the whole level. `metadata` is the level's (without terracl keys), `provenance` the stage's.
std::unique_ptr<TileSink> make_render_sink(const PipelineStage& stage, int width, int height, const Georef& level,
                                           const Metadata& metadata, const Metadata& provenance,
                                           std::function<Device&()> device);

}  // namespace terracl::tile
