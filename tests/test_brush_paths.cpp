// SPDX-License-Identifier: Apache-2.0
// Painted brush strokes (docs/authoring.md, "Regions"): a region given as a `path` with a `radius`
// is the band a disc sweeps along the polyline. A one-vertex path is the disc, bit for bit; a
// painted stroke changes the field only within its band and falloff, and along all of it.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <terracl/edit.hpp>

#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;

Heightfield run(const Heightfield& base, const json& op) {
  EditSession s(test::device(), base);
  s.apply({{"operations", {op}}});
  return s.height();
}

GradientField field(const Heightfield& base, const json& op) {
  EditSession s(test::device(), base);
  s.apply({{"operations", {op}}});
  return s.gradient();
}

double segment_distance(double ax, double ay, double bx, double by, double x, double y) {
  const double ux = bx - ax, uy = by - ay, l2 = ux * ux + uy * uy;
  const double t = std::clamp(((x - ax) * ux + (y - ay) * uy) / l2, 0.0, 1.0);
  return std::hypot(x - ax - t * ux, y - ay - t * uy);
}

TEST(BrushPaths, OneVertexIsTheDiscBitForBit) {
  const Heightfield base = test::smooth_terrain(80, 72, 10.0, 150.0, 3);
  const json ops[] = {
      {{"op", "noise"}, {"amplitude", 12}, {"wavelength", 60}, {"radius", 150}},
      {{"op", "scale_slopes"}, {"factor", 2.5}, {"radius", 120}, {"falloff", 60}},
      {{"op", "freeze"}, {"radius", 90}},
      {{"op", "erode"}, {"steps", 4}, {"radius", 150}, {"falloff", 50}},
  };
  for (json op : ops) {
    json disc = op, path = op;
    disc["center"] = {400, 350};
    path["path"] = {{400, 350}};
    const Heightfield a = run(base, disc), b = run(base, path);
    ASSERT_EQ(a.z, b.z) << op["op"];
  }
}

TEST(BrushPaths, APaintedStrokeChangesItsBandAndNothingElse) {
  const Heightfield base = test::smooth_terrain(96, 80, 10.0, 150.0, 7);
  const double r = 60, falloff = 40;
  const double ax = 150, ay = 200, bx = 800, by = 550;
  const json op = {{"op", "scale_slopes"}, {"factor", 3}, {"radius", r}, {"falloff", falloff},
                   {"path", {{ax, ay}, {bx, by}}}};
  const GradientField g0 = EditSession(test::device(), base).gradient();
  const GradientField g1 = field(base, op);
  size_t changed = 0, outside = 0;
  for (int y = 0; y < base.height; ++y)
    for (int x = 0; x < base.width; ++x) {
      const size_t i = size_t(y) * base.width + x;
      if (g1.gx[i] == g0.gx[i] && g1.gy[i] == g0.gy[i]) continue;
      ++changed;
      // faces sit half a cell from the cell centre
      if (segment_distance(ax, ay, bx, by, x * 10.0, y * 10.0) > r + falloff + 10.0) ++outside;
    }
  EXPECT_GT(changed, 1000u);
  EXPECT_EQ(outside, 0u);
  // Every cell along the stroke, its middle included, is steepened (a factor 3 inside the band).
  for (double t : {0.1, 0.5, 0.9}) {
    const int x = int(std::lround((ax + t * (bx - ax)) / 10)), y = int(std::lround((ay + t * (by - ay)) / 10));
    const size_t i = size_t(y) * base.width + x;
    EXPECT_NEAR(g1.gx[i], 3 * g0.gx[i], 1e-4 + 1e-3 * std::abs(g0.gx[i])) << t;
  }
}

TEST(BrushPaths, FreezeAlongAPathHoldsItsBand) {
  const Heightfield base = test::smooth_terrain(64, 64, 10.0, 100.0, 2);
  EditSession s(test::device(), base);
  s.apply({{"operations", {{{"op", "freeze"}, {"radius", 25}, {"path", {{100, 100}, {500, 100}, {500, 500}}}}}}});
  size_t hard = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool in_band = std::min(segment_distance(100, 100, 500, 100, x * 10.0, y * 10.0),
                                    segment_distance(500, 100, 500, 500, x * 10.0, y * 10.0)) <= 25;
      const bool is_hard = !std::isnan(s.hard_constraints()[size_t(y) * 64 + x]);
      ASSERT_EQ(is_hard, in_band) << x << "," << y;
      hard += is_hard;
    }
  EXPECT_GT(hard, 300u);
}

TEST(BrushPaths, BadPathsNameTheirJsonPath) {
  const Heightfield base = test::smooth_terrain(32, 32, 10.0, 50.0, 1);
  auto error_of = [&](const json& op) {
    EditSession s(test::device(), base);
    try {
      s.validate({{"operations", {op}}});
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of({{"op", "noise"}, {"amplitude", 5}, {"wavelength", 40}, {"radius", 30}, {"path", {{10}}}}).find("/operations/0/path/0"),
            std::string::npos);
  EXPECT_NE(error_of({{"op", "noise"}, {"amplitude", 5}, {"wavelength", 40}, {"radius", 30}, {"path", json::array()}}).find("/operations/0/path"),
            std::string::npos);
  EXPECT_NE(error_of({{"op", "freeze"}, {"path", {{10, 10}, {50, 50}}}}).find("radius"), std::string::npos);
  EXPECT_NE(error_of({{"op", "freeze"}, {"radius", 5}, {"center", {1, 1}}, {"path", {{10, 10}}}}).find("one region"), std::string::npos);
}

}  // namespace
}  // namespace terracl
