#pragma once
// Shared by the host and device paths of render: argument checks and the picture's layout.
#include <cmath>
#include <functional>
#include <string>
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

/// What the layout needs to know of the heights, gathered strip by strip by a streamed render.
struct LayoutScan {
  bool has_nan = false;
  float lo = INFINITY, hi = -INFINITY;  ///< data range, only when a ramp entry is a percentage
};
/// False when the layout of a width x height picture does not depend on the heights (e.g. a
/// hillshade without compute_edges always has its alpha band); throws for value-only modes.
bool layout_needs_scan(int width, int height, const Options& opt);
/// Adds `n` heights to the scan.
void scan_heights(const float* z, size_t n, const Options& opt, LayoutScan& s);
/// The layout of a width x height picture from the scan of all its heights.
PictureLayout picture_layout(int width, int height, const Options& opt, const LayoutScan& s);

/// render() with a given layout, so that strips of one raster share the whole raster's layout.
Image render(const Heightfield& h, const Options& opt, const PictureLayout& l);
Image render(const Heightfield& h, const Options& opt, const PictureLayout& l, Device& device);

/// render_file with the device opened by `open_device` (null: the host) while the first strip is read.
void render_file(const std::string& input, const std::string& output, const Options& opt,
                 const std::function<Device*()>& open_device, const Metadata& meta, int strip_rows);

}  // namespace terracl::render

namespace terracl::render {
/// An all-nodata float raster with h's size and georef (nodata -9999, gdaldem's), its unit and
/// quantity set for opt.mode.
Heightfield value_raster_like(const Heightfield& h, const Options& opt);
}  // namespace terracl::render
