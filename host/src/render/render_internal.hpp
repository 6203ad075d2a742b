// SPDX-License-Identifier: Apache-2.0
#pragma once
// Shared by the host and device paths of render: argument checks and the picture's layout.
#include <cmath>
#include <functional>
#include <cstdint>
#include <string>
#include <vector>
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
/// The colour ramp as the kernels read it (render.cl, render_view.cl through render_ramp.clh):
/// entry elevations with percentages resolved against [zmin, zmax], their RGB, nodata as 0xBBGGRR.
struct DeviceRamp {
  std::vector<float> z;
  std::vector<uint8_t> rgb;
  uint32_t nodata = 0;
};
inline DeviceRamp device_ramp(const ColorRamp& ramp, double zmin, double zmax) {
  DeviceRamp d;
  for (const auto& e : ramp.entries) {
    d.z.push_back(float(e.percent ? zmin + e.value / 100.0 * (zmax - zmin) : e.value));
    d.rgb.insert(d.rgb.end(), e.rgb, e.rgb + 3);
  }
  d.nodata = uint32_t(ramp.nodata_rgb[0]) | uint32_t(ramp.nodata_rgb[1]) << 8 | uint32_t(ramp.nodata_rgb[2]) << 16;
  return d;
}

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
