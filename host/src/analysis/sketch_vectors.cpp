// SPDX-License-Identifier: Apache-2.0
// The sketch's rivers, ridges, peaks and basins as a vector file a GIS opens (GeoJSON, GeoPackage,
// KML, through OGR), in map coordinates: the pixel-coordinate JSON of sketch_to_json is terracl's
// own format, which ogrinfo and QGIS cannot read.
#include "io/gdal_common.hpp"

#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cpl_string.h>
#include <gdal_priv.h>
#include <ogr_feature.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fmt/format.h>

namespace terracl::analysis {
namespace {

const char* vector_driver(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".geojson") return "GeoJSON";
  if (ext == ".gpkg") return "GPKG";
  if (ext == ".kml") return "KML";
  return nullptr;
}

}  // namespace

bool is_sketch_vector_path(const std::string& path) { return vector_driver(path) != nullptr; }

void write_sketch_vectors(const Sketch& s, const Heightfield& h, const std::string& path) {
  const char* driver_name = vector_driver(path);
  if (!driver_name)
    fail("sketch", "{}: vector outputs are .geojson, .gpkg or .kml (.json is terracl's pixel-coordinate JSON)", path);
  io::init_gdal();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver_name);
  if (!drv) fail("sketch", "GDAL has no {} driver", driver_name);
  // Cell centres in map units: the raster's geotransform, or the local metric grid of a raster
  // without one (origin at the south-west corner, as its GeoTIFF carries it).
  const Georef& g = h.georef;
  std::array<double, 6> gt = {0.0, g.cell_x, 0.0, g.cell_y * h.height, 0.0, -g.cell_y};
  if (g.has_geotransform) gt = g.geotransform;
  auto map_x = [&](const Sketch::Point& p) { return gt[0] + (p.x + 0.5) * gt[1] + (p.y + 0.5) * gt[2]; };
  auto map_y = [&](const Sketch::Point& p) { return gt[3] + (p.x + 0.5) * gt[4] + (p.y + 0.5) * gt[5]; };

  OGRSpatialReference srs;
  const bool has_crs = !g.crs_wkt.empty() && srs.importFromWkt(g.crs_wkt.c_str()) == OGRERR_NONE;
  if (has_crs) srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  write_atomically(path, [&](const std::string& tmp) {
    io::GdalFirstError first;
    io::DatasetPtr ds(drv->Create(tmp.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!ds) fail("sketch", "cannot create {} ({})", path, first.message());
    char** lco = nullptr;
    // RFC 7946 GeoJSON is WGS 84 longitude/latitude: OGR reprojects the map coordinates.
    if (std::string(driver_name) == "GeoJSON" && has_crs) lco = CSLSetNameValue(lco, "RFC7946", "YES");
    OGRLayer* layer = ds->CreateLayer("sketch", has_crs ? &srs : nullptr, wkbUnknown, lco);
    CSLDestroy(lco);
    if (!layer) fail("sketch", "cannot create a layer in {} ({})", path, first.message());
    for (const auto& [name, type] : {std::pair{"kind", OFTString}, {"drainage_area_m2", OFTReal}, {"strahler", OFTInteger},
                                     {"elevation_m", OFTReal}, {"relief_m", OFTReal}}) {
      OGRFieldDefn f(name, type);
      if (layer->CreateField(&f) != OGRERR_NONE) fail("sketch", "cannot add field {} to {}", name, path);
    }
    auto add = [&](const char* kind, OGRGeometry* geom, double area, double z, double relief, int strahler = 0) {
      OGRFeature f(layer->GetLayerDefn());
      f.SetField("kind", kind);
      if (area >= 0) f.SetField("drainage_area_m2", area);
      if (strahler > 0) f.SetField("strahler", strahler);
      f.SetField("elevation_m", z);
      if (relief >= 0) f.SetField("relief_m", relief);
      f.SetGeometryDirectly(geom);
      if (layer->CreateFeature(&f) != OGRERR_NONE) fail("sketch", "cannot write a {} to {} ({})", kind, path, first.message());
    };
    for (const auto& [kind, lines] : {std::pair{"river", &s.rivers}, {"ridge", &s.ridges}})
      for (const Sketch::Line& l : *lines) {
        if (l.points.size() < 2) continue;
        auto* ls = new OGRLineString();
        for (const auto& p : l.points) ls->addPoint(map_x(p), map_y(p), p.z);
        add(kind, ls, l.drainage_area_m2, l.points.front().z, -1, l.strahler);
      }
    for (const auto& [kind, points] : {std::pair{"peak", &s.peaks}, {"basin", &s.basins}})
      for (const Sketch::Extremum& e : *points) add(kind, new OGRPoint(map_x(e.p), map_y(e.p), e.p.z), -1, e.p.z, e.relief_m);
    ds.reset();  // flushes; an error on close is a failed write
    if (CPLGetLastErrorType() >= CE_Failure) fail("sketch", "writing {} failed ({})", path, first.message());
  });
}

}  // namespace terracl::analysis
