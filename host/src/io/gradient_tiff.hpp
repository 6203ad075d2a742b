// SPDX-License-Identifier: Apache-2.0
#pragma once
// Gradient fields as a two-band float32 GeoTIFF (band 1 "gx", band 2 "gy"): the format tiled runs
// write window by window (docs/io.md, "Gradient fields"). The EXR path stays; readers accept both.
#include <optional>
#include <string>
#include <terracl/heightfield.hpp>

namespace terracl::io {

/// True when `path` is a GeoTIFF with two bands described gx and gy.
bool is_gradient_geotiff(const std::string& path);
/// Rows [y0, y1) of a gradient GeoTIFF (y0 == y1: the header only), with the whole raster's
/// georef, the convention (terracl:gradient) and the mean elevation; `full_height` gets its rows.
GradientField read_gradient_geotiff_rows(const std::string& path, int y0, int y1, int* full_height);
/// Writes `g` atomically as a tiled two-band GeoTIFF (the same writer as a tiled run's).
void write_gradient_geotiff(const GradientField& g, const std::string& path);

/// What a gradient GeoTIFF stores besides the cells: `g`'s metadata, its mean elevation as text
/// (terracl:mean_elevation) and the source's nodata value (terracl:height_nodata; the gradient
/// bands themselves have none, so a gradient of 0 is never taken for nodata).
Metadata gradient_tiff_metadata(const Metadata& md, double mean_elevation, const std::optional<double>& height_nodata);
/// The georef a gradient GeoTIFF is created with: `g` without its nodata value.
Georef gradient_tiff_georef(const Georef& g);

}  // namespace terracl::io
