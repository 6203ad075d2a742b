// SPDX-License-Identifier: Apache-2.0
// `watershed --points X,Y;...`: the basin of a pour point holds exactly the cells whose D8
// accumulation it counts, and a nested point cuts its own basin out of the outer one.
#include "test_helpers.hpp"

#include <terracl/analysis.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <memory>

#include <ogr_spatialref.h>

using namespace terracl;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

size_t count(const Heightfield& h, float v) {
  size_t n = 0;
  for (float z : h.z) n += z == v;
  return n;
}

}  // namespace

TEST(Watershed, BasinsHoldTheirAccumulationAndNest) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const Heightfield h = read_heightfield(in);
  const analysis::D8Result d8 = analysis::d8_flow(h);
  // The cell of largest accumulation, and its largest donor one step upstream.
  size_t outer = 0;
  for (size_t i = 0; i < d8.cells.size(); ++i)
    if (d8.cells[i] > d8.cells[outer]) outer = i;
  const int w = h.width, ox = int(outer % w), oy = int(outer / w);
  size_t inner = outer;
  for (int d = 0; d < 8; ++d) {
    const int u = ox - analysis::kDx[d], v = oy - analysis::kDy[d];
    if (u < 0 || v < 0 || u >= w || v >= h.height) continue;
    const size_t j = size_t(v) * w + u;
    if (d8.dir[j] == d && (inner == outer || d8.cells[j] > d8.cells[inner])) inner = j;
  }
  ASSERT_NE(inner, outer);
  const auto& gt = h.georef.geotransform;
  auto at = [&](size_t i) {
    return fmt::format("{:.10f},{:.10f}", gt[0] + (double(i % w) + 0.5) * gt[1], gt[3] + (double(i / w) + 0.5) * gt[5]);
  };
  auto r = test::run_cli("watershed " + q(in) + " -o " + q(dir.path("one.tif")) + " --points '" + at(outer) + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield one = read_heightfield(dir.path("one.tif"));
  EXPECT_EQ(double(count(one, 1.0f)), d8.cells[outer]);
  EXPECT_EQ(one.count_nodata(), h.size() - size_t(d8.cells[outer]));

  r = test::run_cli("watershed " + q(in) + " -o " + q(dir.path("two.tif")) + " --points '" + at(outer) + ";" + at(inner) + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield two = read_heightfield(dir.path("two.tif"));
  EXPECT_EQ(double(count(two, 2.0f)), d8.cells[inner]);
  EXPECT_EQ(double(count(two, 1.0f)), d8.cells[outer] - d8.cells[inner]);

  // Snapping a point one cell off the channel back onto it.
  const size_t beside = (ox + 1 < w ? outer + 1 : outer - 1);
  r = test::run_cli("watershed " + q(in) + " -o " + q(dir.path("snap.tif")) + " --points '" + at(beside) + "' --snap 1");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(double(count(read_heightfield(dir.path("snap.tif")), 1.0f)), d8.cells[outer]);

  for (const auto& [points, why] : {std::pair{"abc", "is not X,Y"}, {"0,0", "lies outside the raster"}, {";", "at least one"}}) {
    r = test::run_cli("watershed " + q(in) + " -o " + q(dir.path("bad.tif")) + " --points '" + points + "'");
    EXPECT_EQ(r.exit_code, 2) << points << "\n" << r.out;
    EXPECT_NE(r.out.find(why), std::string::npos) << r.out;
  }
}

// Pour points from a vector file in another CRS: a GeoJSON (WGS 84 longitude/latitude) point on
// the outlet of a UTM raster gives the same basin as its UTM coordinates.
TEST(Watershed, PourPointsFromAGeoJsonInAnotherCrs) {
  test::TempDir dir;
  const std::string utm = dir.path("utm.tif");
  auto r = test::run_cli("warp " + q(test::data_path("crops/presidential_128x96.tif")) + " -o " + q(utm) +
                         " -t_srs EPSG:32619 -tr 100 100 -ot Float32");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield h = read_heightfield(utm);
  const analysis::D8Result d8 = analysis::d8_flow(h);
  size_t outer = 0;
  for (size_t i = 0; i < d8.cells.size(); ++i)
    if (d8.cells[i] > d8.cells[outer]) outer = i;
  const auto& gt = h.georef.geotransform;
  double x = gt[0] + (double(outer % h.width) + 0.5) * gt[1], y = gt[3] + (double(outer / h.width) + 0.5) * gt[5];
  OGRSpatialReference from, to;
  from.importFromEPSG(32619);
  to.importFromEPSG(4326);
  from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> t(OGRCreateCoordinateTransformation(&from, &to));
  ASSERT_TRUE(t && t->Transform(1, &x, &y));
  std::ofstream(dir.path("pour.geojson")) << fmt::format(
      R"({{"type": "FeatureCollection", "features": [{{"type": "Feature", "properties": {{}},
          "geometry": {{"type": "Point", "coordinates": [{:.12f}, {:.12f}]}}}}]}})", x, y);
  r = test::run_cli("watershed " + q(utm) + " -o " + q(dir.path("ws.tif")) + " --points " + q(dir.path("pour.geojson")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(double(count(read_heightfield(dir.path("ws.tif")), 1.0f)), d8.cells[outer]);
  // A file of lines is not pour points.
  std::ofstream(dir.path("line.geojson"))
      << R"({"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
            "geometry": {"type": "LineString", "coordinates": [[-71.3, 44.3], [-71.2, 44.3]]}}]})";
  r = test::run_cli("watershed " + q(utm) + " -o " + q(dir.path("ws2.tif")) + " --points " + q(dir.path("line.geojson")));
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("pour points are points"), std::string::npos) << r.out;
}
