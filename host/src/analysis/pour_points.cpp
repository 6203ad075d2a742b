// SPDX-License-Identifier: Apache-2.0
// Pour points from a vector file (GeoJSON, GeoPackage, Shapefile, KML: any OGR source) in the
// raster's CRS, for the watershed stage.
#include "io/gdal_common.hpp"

#include <terracl/analysis.hpp>
#include <terracl/error.hpp>

#include <gdal_priv.h>
#include <ogr_feature.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <memory>

namespace terracl::analysis {

std::vector<std::array<double, 2>> read_pour_points(const std::string& path, const Georef& g) {
  io::init_gdal();
  io::GdalFirstError first;
  io::DatasetPtr ds(
      static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!ds || ds->GetLayerCount() < 1)
    throw UsageError("watershed", fmt::format("points: {} is not a vector file OGR opens ({})", path, first.message()));
  OGRLayer* layer = ds->GetLayer(0);
  // Points in another CRS than the raster's are transformed (a GeoJSON is WGS 84 by definition).
  std::unique_ptr<OGRCoordinateTransformation> to_raster;
  if (const OGRSpatialReference* from = layer->GetSpatialRef(); from && !g.crs_wkt.empty()) {
    OGRSpatialReference to;
    to.importFromWkt(g.crs_wkt.c_str());
    to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    OGRSpatialReference src(*from);
    src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (!src.IsSame(&to)) {
      to_raster.reset(OGRCreateCoordinateTransformation(&src, &to));
      if (!to_raster)
        throw UsageError("watershed", fmt::format("points: cannot transform {}'s CRS to the raster's ({})", path,
                                                  first.message()));
    }
  }
  std::vector<std::array<double, 2>> out;
  for (auto& f : *layer) {
    const OGRGeometry* geom = f->GetGeometryRef();
    if (!geom) continue;
    auto add = [&](const OGRPoint* p) {
      double x = p->getX(), y = p->getY();
      if (to_raster && !to_raster->Transform(1, &x, &y))
        throw UsageError("watershed", fmt::format("points: a point of {} cannot be transformed to the raster's CRS", path));
      out.push_back({x, y});
    };
    const OGRwkbGeometryType t = wkbFlatten(geom->getGeometryType());
    if (t == wkbPoint) {
      add(geom->toPoint());
    } else if (t == wkbMultiPoint) {
      for (const OGRPoint* p : *geom->toMultiPoint()) add(p);
    } else {
      throw UsageError("watershed", fmt::format("points: {} holds a {}; pour points are points", path,
                                                OGRGeometryTypeToName(geom->getGeometryType())));
    }
  }
  if (out.empty()) throw UsageError("watershed", fmt::format("points: {} holds no point", path));
  return out;
}

}  // namespace terracl::analysis
