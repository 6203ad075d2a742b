// SPDX-License-Identifier: Apache-2.0
// Constraint rasterisation, the priority rule and the constraint JSON format.
#include "test_helpers.hpp"

#include <terracl/constraints.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/reconstruct.hpp>

#include <cstring>

using namespace terracl;
using nlohmann::json;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(Constraints, PriorityRulePointBeatsPolylineBeatsPolygonBeatsRaster) {
  ConstraintSet c(10, 10);
  Heightfield mask(10, 10, 1.f), elev(10, 10, 5.f);
  c.add_rasters(mask, elev);
  c.add_polygon({{1, 1}, {8, 1}, {8, 8}, {1, 8}}, 50.0);
  c.add_polyline({{{2, 5, 100}, {7, 5, 100}}}, 1.0);
  c.add_point(4, 5, 700);
  EXPECT_EQ(c.value(0, 0), 5.f);     // raster only
  EXPECT_EQ(c.value(3, 3), 50.f);    // polygon over raster
  EXPECT_EQ(c.value(6, 5), 100.f);   // polyline over polygon
  EXPECT_EQ(c.value(4, 5), 700.f);   // point over everything
  // a lower-priority constraint added later does not override
  c.add_polygon({{3, 4}, {5, 4}, {5, 6}, {3, 6}}, 1.0);
  EXPECT_EQ(c.value(4, 5), 700.f);
  EXPECT_EQ(c.count(), 100u);
}

TEST(Constraints, SameKindIsAveraged) {
  ConstraintSet c(5, 5);
  c.add_point(2, 2, 10);
  c.add_point(2.2, 1.9, 20);
  EXPECT_FLOAT_EQ(c.value(2, 2), 15.f);
  c.add_polygon({{-0.5, -0.5}, {4.4, -0.5}, {4.4, 4.4}, {-0.5, 4.4}}, 1.0);
  c.add_polygon({{-0.5, -0.5}, {4.4, -0.5}, {4.4, 4.4}, {-0.5, 4.4}}, 3.0);
  EXPECT_FLOAT_EQ(c.value(0, 0), 2.f);
  EXPECT_FLOAT_EQ(c.value(2, 2), 15.f);
}

TEST(Constraints, PolylineWidthAndInterpolatedZ) {
  ConstraintSet c(20, 11);
  c.add_polyline({{{0, 5, 0}, {19, 5, 190}}}, 3.0);
  for (int x = 0; x < 20; ++x) {
    EXPECT_TRUE(c.is_hard(x, 4) && c.is_hard(x, 5) && c.is_hard(x, 6)) << x;
    EXPECT_FALSE(c.is_hard(x, 3) || c.is_hard(x, 7)) << x;
    EXPECT_NEAR(c.value(x, 5), 10.0 * x, 1e-4);
  }
  // diagonal lines stay connected
  ConstraintSet d(10, 10);
  d.add_polyline({{{0, 0, 1}, {9, 9, 1}}}, 1.0);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(d.is_hard(k, k));
}

TEST(Constraints, JsonPixelsMapAndFreeze) {
  Georef geo;
  geo.has_geotransform = true;
  geo.geotransform = {1000.0, 10.0, 0.0, 5000.0, 0.0, -10.0};
  Heightfield current(20, 20, 42.f);
  ConstraintSet c(20, 20);
  add_constraints_json(c,
                       json::parse(R"({"points": [{"x": 3, "y": 4, "z": 12.5}],
                       "polylines": [{"points": [[0, 10, 1], [19, 10, 1]], "width": 1}],
                       "polygons": [{"points": [[12, 12], [18, 12], [18, 18], [12, 18]], "z": "freeze"}]})"),
                       geo, &current, "c.json");
  EXPECT_EQ(c.value(3, 4), 12.5f);
  EXPECT_EQ(c.value(7, 10), 1.f);
  EXPECT_EQ(c.value(15, 15), 42.f);
  ConstraintSet m(20, 20);
  // map coordinates of the centre of cell (5, 2): x = 1000 + 5.5*10, y = 5000 - 2.5*10
  add_constraints_json(m, json::parse(R"({"units": "map", "points": [{"x": 1055, "y": 4975, "z": 7}]})"), geo, nullptr,
                       "m.json");
  EXPECT_EQ(m.value(5, 2), 7.f);
  EXPECT_EQ(m.count(), 1u);
}

TEST(Constraints, BadJsonErrorsNameThePath) {
  Georef geo;
  auto err = [&](const std::string& text) {
    return error_of([&] {
      ConstraintSet c(10, 10);
      add_constraints_json(c, json::parse(text), geo, nullptr, "c.json");
    });
  };
  EXPECT_NE(err(R"({"points": [{"x": 1, "y": 1, "z": 1}, {"x": 30, "y": 1, "z": 1}]})").find("c.json/points/1"),
            std::string::npos);
  EXPECT_NE(err(R"({"points": [{"x": 1, "y": 1, "z": null}]})").find("c.json/points/0/z"), std::string::npos);
  EXPECT_NE(err(R"({"points": [{"x": 1, "y": 1}]})").find("c.json/points/0/z: missing z"), std::string::npos);
  EXPECT_NE(err(R"({"polylines": [{"points": [[1, 1], [1, 2]]}]})").find("c.json/polylines/0/points/0: missing z"),
            std::string::npos);
  EXPECT_NE(err(R"({"polygons": [{"points": [[1, 1], [5, 1], [5, 5]]}]})").find("c.json/polygons/0: missing \"z\""),
            std::string::npos);
  EXPECT_NE(err(R"({"polylines": [{"points": [[1, 1, 1], [1, 2]]}]})").find("c.json/polylines/0/points/1"),
            std::string::npos);
  EXPECT_NE(err(R"({"polylines": [{"points": [[1, 1, 1]], "width": -2}]})").find("width"), std::string::npos);
  EXPECT_NE(err(R"({"polygons": [{"points": [[1, 1], [2, 2]], "z": 3}]})").find("c.json/polygons/0"),
            std::string::npos);
  EXPECT_NE(err(R"({"polygons": [{"points": [[1, 1], [5, 1], [5, 5]], "z": "freeze"}]})").find("freeze"),
            std::string::npos);
  EXPECT_NE(err(R"({"polygons": [{"points": [[1, 1], [5, 1], [5, 5]], "z": "high"}]})").find("c.json/polygons/0/z"),
            std::string::npos);
  EXPECT_NE(err(R"({"pointz": []})").find("c.json/pointz"), std::string::npos);
  EXPECT_NE(err(R"({"units": "map", "points": []})").find("georeferenced"), std::string::npos);
  EXPECT_NE(err(R"([1, 2])").find("JSON object"), std::string::npos);
}

// Where the current elevations are known (--initial, a pipeline's previous stage, erosion's input)
// z may be omitted: points and polyline vertices take the current elevation of their nearest cell,
// polygons are frozen. Points may be [x, y(, z)] arrays; "georeferenced" is an alias of "map".
TEST(Constraints, OmittedZTakesTheCurrentElevation) {
  Heightfield cur(10, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 10; ++x) cur.at(x, y) = float(100 * y + x);
  cur.georef.geotransform = {500.0, 10.0, 0.0, 900.0, 0.0, -10.0};
  cur.georef.has_geotransform = true;
  ConstraintSet c(10, 8);
  add_constraints_json(c, json::parse(R"({"units": "georeferenced",
      "points": [[515, 875], {"x": 575, "y": 855, "z": 3}],
      "polylines": [{"points": [[505, 835], [545, 835]]}],
      "polygons": [{"points": [[560, 845], [595, 845], [595, 825], [560, 825]]}]})"),
                       cur.georef, &cur, "c.json");
  EXPECT_EQ(c.value(1, 2), cur.at(1, 2));  // [515, 875] -> cell (1, 2)
  EXPECT_EQ(c.value(7, 4), 3.f);           // an explicit z is kept
  EXPECT_EQ(c.value(0, 6), cur.at(0, 6));  // polyline ends take their cells' elevations,
  EXPECT_EQ(c.value(4, 6), cur.at(4, 6));
  EXPECT_NEAR(c.value(2, 6), 0.5 * (cur.at(0, 6) + cur.at(4, 6)), 1e-3);  // interpolated between them
  EXPECT_EQ(c.value(7, 6), cur.at(7, 6));  // inside the frozen polygon
  EXPECT_TRUE(std::isnan(c.value(0, 0)));
}

TEST(Constraints, ConflictingConstraintsInASolveFollowThePriorityRule) {
  Heightfield h = test::smooth_terrain(40, 40, 10.0, 100.0, 3);
  GradientField g = extract_gradient(test::device(), h);
  ConstraintSet c(40, 40);
  c.add_polygon({{10, 10}, {20, 10}, {20, 20}, {10, 20}}, 900.0);
  c.add_point(15, 15, 1100.0);  // inside the polygon: the point wins
  c.add_polyline({{{5, 30, 1000}, {35, 30, 1000}}}, 1.0);
  c.add_point(20, 30, 950.0);   // on the polyline: the point wins
  ReconstructResult r = reconstruct(test::device(), g, c);
  EXPECT_EQ(r.height.at(15, 15), 1100.f);
  EXPECT_EQ(r.height.at(12, 12), 900.f);
  EXPECT_EQ(r.height.at(20, 30), 950.f);
  EXPECT_EQ(r.height.at(25, 30), 1000.f);
  for (float z : r.height.z) ASSERT_TRUE(std::isfinite(z));
}

// hard_cells runs in threads over 64k-cell chunks above 256k cells: the list must be the
// row-major scan's, values resolved as value(), for any layout (chunk edges, averaged cells,
// a hard last cell, an empty chunk run).
TEST(Constraints, HardCellListInThreadsIsTheRowMajorScan) {
  const int W = 701, H = 503;  // 352k cells: 6 chunks, threaded
  ConstraintSet c(W, H);
  uint32_t s = 12345;
  for (int k = 0; k < 9000; ++k) {
    s = s * 1664525u + 1013904223u;
    const int x = int(s % W), y = int((s >> 12) % (H / 2));  // the lower half stays free
    c.add_cell(x, y, double(k) * 0.37, ConstraintKind::Raster, "t");
    if (k % 7 == 0) c.add_cell(x, y, 1.0 + k, ConstraintKind::Raster, "t");  // averaged
  }
  c.add_cell(65535 % W, 65535 / W, 5.0, ConstraintKind::Point, "t");  // last cell of chunk 0
  c.add_cell(65536 % W, 65536 / W, 6.0, ConstraintKind::Point, "t");  // first of chunk 1
  c.add_cell(W - 1, H - 1, 7.0, ConstraintKind::Point, "t");
  std::vector<uint32_t> idx;
  std::vector<float> val;
  c.hard_cells(idx, val);
  std::vector<uint32_t> want_idx;
  std::vector<float> want_val;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (c.is_hard(x, y)) want_idx.push_back(uint32_t(size_t(y) * W + x)), want_val.push_back(c.value(x, y));
  ASSERT_EQ(idx.size(), c.count());
  EXPECT_EQ(idx, want_idx);
  ASSERT_EQ(val.size(), want_val.size());
  EXPECT_EQ(0, std::memcmp(val.data(), want_val.data(), val.size() * sizeof(float)));
  ConstraintSet empty(W, H);
  empty.hard_cells(idx, val);
  EXPECT_TRUE(idx.empty() && val.empty());
}
