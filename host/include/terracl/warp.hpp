// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Resampling and reprojection on GDAL's warper (the library behind `gdalwarp`), and resizing to
/// game-engine heightmap sizes. Nodata cells (NaN) stay nodata; cells outside the source's
/// footprint become nodata (gdalwarp writes 0 there unless given -dstnodata).
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace terracl {

struct WarpOptions {
  /// Target CRS as gdalwarp's -t_srs takes it ("EPSG:32619", a WKT or PROJ string); "" keeps the CRS.
  std::string t_srs;
  /// Target cell size in target CRS units (-tr xres yres; positive numbers).
  std::optional<std::array<double, 2>> tr;
  /// Target size in cells (-ts width height); 0 in one of them keeps the aspect ratio.
  std::optional<std::array<int, 2>> ts;
  /// near, bilinear, cubic, cubicspline, lanczos or average (gdalwarp's -r).
  std::string resampling = "near";
  /// Map window ulx uly lrx lry in target CRS units (gdal_translate's -projwin, which is
  /// gdalwarp's -te ulx lry lrx uly).
  std::optional<std::array<double, 4>> projwin;
};

/// The resampling methods warp accepts.
const std::vector<std::string>& warp_resamplings();

/// The gdalwarp arguments that reproduce `warp(h, o)` on a float32 file of `h` ("-r bilinear -tr
/// 30 30 ..."), for messages and the docs' comparison.
std::vector<std::string> gdalwarp_arguments(const WarpOptions& o, bool source_has_nodata);

/// Warps `h` (which must have a geotransform for --t-srs/--tr/--projwin; a raster without one is
/// treated as a local grid of its cell size). Throws "<stage>: ..." on bad options or GDAL errors.
Heightfield warp(const Heightfield& h, const WarpOptions& o, const Progress& progress = {},
                 const std::string& stage = "warp");

/// Engine heightmap sizes (vertices per side): Unreal's recommended landscape sizes and Unity's
/// 2^n+1 terrains. Name -> size, e.g. "unreal-1009" -> 1009.
const std::vector<std::pair<std::string, int>>& engine_presets();
/// Size of a preset; throws naming `stage` and listing the presets when unknown.
int engine_preset_size(const std::string& name, const std::string& stage = "resize");

/// Resizes to width x height cells over the same extent (GDAL's area convention: cell size =
/// extent / cells), by warp with -ts.
Heightfield resize(const Heightfield& h, int width, int height, const std::string& resampling = "bilinear",
                   const Progress& progress = {}, const std::string& stage = "resize");

/// How a 16-bit heightmap of vertical range [zmin, zmax] (codes lo..65535; lo = 1 when code 0 is
/// reserved for nodata) and cells of `cell_x` x `cell_y` metres imports at true scale.
struct EngineScale {
  double unreal_z_scale;      ///< Landscape Scale Z (percent): 100 spans 512 m over the 16-bit range
  double unreal_x_scale;      ///< Landscape Scale X = cell width (east-west) in cm
  double unreal_y_scale;      ///< Landscape Scale Y = cell height (north-south) in cm: differs from X on
                              ///< non-square (e.g. geographic) cells
  double unreal_z_location;   ///< Landscape Location Z in cm, so that elevations keep their datum
  double unity_height;        ///< Unity Terrain Height (m): the full code range 0..65535
  double unity_position_y;    ///< Unity terrain Position Y (m): the elevation of code 0
};
EngineScale engine_scale(double zmin, double zmax, bool reserve_nodata, double cell_x, double cell_y);
/// Square cells of `cell` metres.
inline EngineScale engine_scale(double zmin, double zmax, bool reserve_nodata, double cell) {
  return engine_scale(zmin, zmax, reserve_nodata, cell, cell);
}
/// The sidecar / metadata entries of engine_scale ("unreal_z_scale", ...).
std::vector<std::pair<std::string, double>> engine_scale_entries(const EngineScale& s);
/// What to do about non-square cells, for engine exports: a geographic raster needs a warp to a
/// metric CRS; a metric one was resized out of its extent's proportions and needs a square extent.
std::string square_cell_advice(const Heightfield& h);
/// engine_scale of `h` written to 16 bits over its data range (code 0 reserved when it has
/// nodata), recorded as "engine:<entry>" metadata (GeoTIFF tag engine_<entry>, EXR attribute; PNG16/RAW16 sidecars recompute
/// it for the range they are written with).
EngineScale record_engine_scale(Heightfield& h);

}  // namespace terracl
