// SPDX-License-Identifier: Apache-2.0
// `amplify --resample-exemplar`: an exemplar at another resolution or CRS is warped by GDAL to the
// output's cell size (and the input's CRS when both are known and differ). Averaging is the model
// of a coarser DEM cell (the amplification's input is the block mean of its output). The warp is the
// shared one of `terracl warp` (io/warp.cpp); this file only decides its target and fills the
// corners a reprojection leaves empty.
#include "amplify/exemplar_warp.hpp"

#include <terracl/error.hpp>
#include <terracl/warp.hpp>

#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <string>

namespace terracl {

Heightfield resample_exemplar(const Heightfield& ex, const Georef& target, double cell_x, double cell_y,
                              const std::string& name) {
  if (!ex.georef.has_geotransform)
    fail("amplify", "--resample-exemplar: {} has no georeferencing: its cell size is unknown", name);
  if (!(cell_x > 0) || !(cell_y > 0)) fail("amplify", "--resample-exemplar: the output cell size is unknown");
  // Averaging can only make cells coarser: a coarser exemplar has no detail to give.
  if (ex.georef.cell_x > 1.05 * cell_x || ex.georef.cell_y > 1.05 * cell_y)
    fail("amplify", "--resample-exemplar: {}'s {:.3f} x {:.3f} m cells are coarser than the output's {:.3f} x {:.3f} m; "
         "resampling cannot add detail", name, ex.georef.cell_x, ex.georef.cell_y, cell_x, cell_y);
  bool reproject = false;
  if (!ex.georef.crs_wkt.empty() && !target.crs_wkt.empty() && target.has_geotransform) {
    OGRSpatialReference a, b;
    a.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    b.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (a.importFromWkt(ex.georef.crs_wkt.c_str()) == OGRERR_NONE && b.importFromWkt(target.crs_wkt.c_str()) == OGRERR_NONE)
      reproject = !a.IsSame(&b);
  }
  // Target resolution in the units of the target CRS (the input's when reprojecting, else the
  // exemplar's): the metric cell size scaled by the grid's metres per unit.
  const Georef& g = reproject ? target : ex.georef;
  const double rx = std::fabs(g.geotransform[1]) * cell_x / g.cell_x, ry = std::fabs(g.geotransform[5]) * cell_y / g.cell_y;
  WarpOptions wo;
  wo.resampling = "average";
  wo.tr = std::array<double, 2>{rx, ry};
  if (reproject) wo.t_srs = target.crs_wkt;
  Heightfield out;
  try {
    out = warp(ex, wo, {}, "amplify");
  } catch (const Error& e) {
    fail("amplify", "--resample-exemplar: GDAL could not warp {} ({})", name, e.what());
  }
  const int w = out.width, h = out.height;
  out.metadata = ex.metadata;
  // Cells outside the source (a reprojected exemplar's corners) are filled smoothly; the dictionary
  // drops flat patches, so they add no fake detail.
  if (out.count_nodata() == out.size()) fail("amplify", "--resample-exemplar: nothing of {} is left after the warp", name);
  if (out.count_nodata() > 0) fill_nodata_harmonic(out);
  out.metadata["amplify_exemplar_resampled"] =
      fmt::format("{}: {}x{} at {:.3f} x {:.3f} m -> {}x{} at {:.3f} x {:.3f} m{}", name, ex.width, ex.height,
                  ex.georef.cell_x, ex.georef.cell_y, w, h, out.georef.cell_x, out.georef.cell_y, reproject ? ", reprojected" : "");
  return out;
}

}  // namespace terracl
