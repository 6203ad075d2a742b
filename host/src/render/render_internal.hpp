#pragma once
// Shared by the host and device paths of render: argument checks and the picture's layout.
#include <terracl/render.hpp>

namespace terracl::render {

/// Throws a clear error for an empty grid, a bad sun position, slope_max or cell size.
void check_options(const Heightfield& h, const Options& opt);

struct PictureLayout {
  bool grey = false;   ///< hillshade and slope pictures are grey, the others RGB
  bool alpha = false;  ///< some pixel is nodata (a nodata cell, or the border without compute_edges)
  int channels = 3;
  double zmin = 0, zmax = 0;  ///< data range, only computed when a ramp entry is a percentage
};
/// Layout of the picture of `h` (one pass over the heights); throws for value-only modes.
PictureLayout picture_layout(const Heightfield& h, const Options& opt);

}  // namespace terracl::render

namespace terracl::render {
/// An all-nodata float raster with h's size and georef (nodata -9999, gdaldem's), its unit and
/// quantity set for opt.mode.
Heightfield value_raster_like(const Heightfield& h, const Options& opt);
}  // namespace terracl::render
