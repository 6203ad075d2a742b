// SPDX-License-Identifier: Apache-2.0
// `sketch --json x.geojson|x.gpkg`: rivers, ridges, peaks and basins as a vector file a GIS opens,
// in map coordinates, the same features as terracl's pixel-coordinate JSON.
#include "test_helpers.hpp"

#include <terracl/io.hpp>

#include <gdal_priv.h>
#include <ogr_feature.h>
#include <ogr_geometry.h>
#include <ogrsf_frmts.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <map>

using namespace terracl;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

struct Closer {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

std::map<std::string, int> kinds_in(const std::string& path, OGREnvelope* env = nullptr, std::string* crs = nullptr) {
  GDALAllRegister();
  std::unique_ptr<GDALDataset, Closer> ds(
      static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  EXPECT_TRUE(ds) << path;
  std::map<std::string, int> n;
  if (!ds) return n;
  OGRLayer* layer = ds->GetLayer(0);
  if (crs && layer->GetSpatialRef()) {
    const char* name = layer->GetSpatialRef()->GetAuthorityCode(nullptr);
    *crs = name ? name : "";
  }
  if (env) layer->GetExtent(env);
  for (auto& f : *layer) ++n[f->GetFieldAsString("kind")];
  return n;
}

std::map<std::string, int> kinds_in_json(const std::string& path) {
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  std::map<std::string, int> n;
  for (const auto& [key, kind] : {std::pair{"rivers", "river"}, {"ridges", "ridge"}, {"peaks", "peak"}, {"basins", "basin"}})
    if (j.at(key).size()) n[kind] = int(j.at(key).size());
  return n;
}

}  // namespace

TEST(SketchVectors, GeoJsonAndGeoPackageInMapCoordinates) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");  // EPSG:4326
  auto r = test::run_cli("sketch " + q(in) + " -o " + q(dir.path("s.png")) +
                         " --json " + q(dir.path("s.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  r = test::run_cli("sketch " + q(in) + " -o " + q(dir.path("s2.png")) +
                    " --json " + q(dir.path("s.geojson")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // ogrinfo (the program a GIS user tries first) opens it.
  ASSERT_EQ(std::system(("ogrinfo -ro -so " + q(dir.path("s.geojson")) + " >/dev/null 2>&1").c_str()), 0);
  const auto want = kinds_in_json(dir.path("s.json"));
  ASSERT_GT(want.count("river"), 0u);
  OGREnvelope env;
  EXPECT_EQ(kinds_in(dir.path("s.geojson"), &env), want);
  // RFC 7946: longitude/latitude inside the crop's footprint.
  const Heightfield h = read_heightfield(in);
  const auto& gt = h.georef.geotransform;
  EXPECT_GE(env.MinX, gt[0]);
  EXPECT_LE(env.MaxX, gt[0] + gt[1] * h.width);
  EXPECT_GE(env.MinY, gt[3] + gt[5] * h.height);
  EXPECT_LE(env.MaxY, gt[3]);

  // A projected raster to a GeoPackage: UTM metres and the raster's CRS.
  r = test::run_cli("warp " + q(in) + " -o " + q(dir.path("utm.tif")) + " -t_srs EPSG:32619 -tr 90 90 -ot Float32");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  r = test::run_cli("sketch " + q(dir.path("utm.tif")) + " -o " + q(dir.path("s3.png")) + " --json " + q(dir.path("s.gpkg")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::string crs;
  const auto got = kinds_in(dir.path("s.gpkg"), &env, &crs);
  EXPECT_GT(got.at("river"), 0);
  EXPECT_EQ(crs, "32619");
  EXPECT_GT(env.MinX, 100000.0);  // easting in metres, not a column index
  EXPECT_GT(env.MinY, 4000000.0);
}
