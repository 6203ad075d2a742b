// SPDX-License-Identifier: Apache-2.0
// Gradient fields as a two-band float32 GeoTIFF (gradient_tiff.hpp).
#include "io/gradient_tiff.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>

#include "io/gdal_window.hpp"
#include "io/io_common.hpp"

namespace terracl::io {
namespace {
constexpr const char* kMean = "terracl:mean_elevation";
constexpr const char* kNodata = "terracl:height_nodata";
}  // namespace

Metadata gradient_tiff_metadata(const Metadata& md, double mean_elevation, const std::optional<double>& height_nodata) {
  Metadata out = md;
  // As text, as the EXR stores it: a float attribute would lose centimetres at mountain elevations.
  if (std::isfinite(mean_elevation)) out[kMean] = fmt::format("{:.17g}", mean_elevation);
  if (height_nodata) out[kNodata] = fmt::format("{:.17g}", *height_nodata);
  return out;
}

Georef gradient_tiff_georef(const Georef& g) {
  Georef out = g;
  out.nodata.reset();
  return out;
}

bool is_gradient_geotiff(const std::string& path) {
  if (sniff_magic(path) != "TIFF") return false;
  try {
    GdalWindowReader r(path);
    return r.bands() == 2 && r.band_description(1) == "gx" && r.band_description(2) == "gy";
  } catch (const Error&) {
    return false;  // the heightfield reader reports what is wrong with it
  }
}

GradientField read_gradient_geotiff_rows(const std::string& path, int y0, int y1, int* full_height) {
  require_readable(path);
  GdalWindowReader r(path);
  if (r.bands() != 2 || r.band_description(1) != "gx" || r.band_description(2) != "gy")
    fail("io", "{}: a gradient GeoTIFF has 2 bands described gx and gy; this one has {} band(s) ({}, {})", path,
         r.bands(), r.band_description(1), r.band_description(2));
  require_raster_size("io", path, r.width(), r.height(), 16);
  if (full_height) *full_height = r.height();
  if (y0 < 0 || y1 < y0 || y1 > r.height())
    fail("io", "{}: rows [{}, {}) are outside the gradient's {} rows", path, y0, y1, r.height());
  GradientField g(r.width(), y1 - y0);
  g.georef = r.header().georef;
  g.metadata = r.header().metadata;
  if (y1 > y0) {
    const Heightfield gx = r.read(0, y0, r.width(), y1 - y0, 1), gy = r.read(0, y0, r.width(), y1 - y0, 2);
    g.gx = gx.z;
    g.gy = gy.z;
  }
  if (auto it = g.metadata.find(kMean); it != g.metadata.end()) {
    g.mean_elevation = std::strtod(it->second.c_str(), nullptr);
    g.metadata.erase(it);
  }
  if (auto it = g.metadata.find(kNodata); it != g.metadata.end()) {
    g.georef.nodata = std::strtod(it->second.c_str(), nullptr);
    g.metadata.erase(it);
  }
  for (size_t i = 0; i < g.size(); ++i)
    if (!std::isfinite(g.gx[i]) || !std::isfinite(g.gy[i]))
      fail("io", "{}: gradient has a non-finite value at cell ({}, {})", path, i % g.width, y0 + i / g.width);
  return g;
}

void write_gradient_geotiff(const GradientField& g, const std::string& path) {
  require_writable_folder(path);
  Heightfield band(g.width, g.height);
  GeoTiffWindowWriter w(path, g.width, g.height, gradient_tiff_georef(g.georef),
                        gradient_tiff_metadata(g.metadata, g.mean_elevation, g.georef.nodata), {}, 2);
  band.z = g.gx;
  w.write(0, 0, band, 0, 0, g.width, g.height, 1);
  band.z = g.gy;
  w.write(0, 0, band, 0, 0, g.width, g.height, 2);
  w.commit();
}

}  // namespace terracl::io
