// SPDX-License-Identifier: Apache-2.0
// Strokes placed relative to the ground: the default stroke of every landform tool, on a flat base
// and on a real DEM (N44W072), makes a finite landform of its sign and moves no cell against that
// sign by more than 1 m (no moat beside a ridge, no lobe beside a valley); a relative crest sits
// `height` above the terrain under it; a flat base keeps its far-field level; constraints that cut
// the terrain say so.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>

using namespace terracl;
using nlohmann::json;

namespace {

struct Tool {
  std::string name;
  int sign;  // +1 raises, -1 lowers
  bool point;
};
const std::vector<Tool> kTools = {{"crest", 1, false},   {"free_crest", 1, false}, {"mountain_range", 1, false},
                                  {"cliff", 1, false},   {"peak", 1, true},        {"volcano", 1, true},
                                  {"river", -1, false},  {"ravine", -1, false},    {"canyon", -1, false}};

// The tool's default stroke across the middle of an n x n grid (cells): only where it is.
json default_stroke(const Tool& t, int n) {
  json op = {{"op", t.name}};
  if (t.point) op["center"] = {n / 2, n / 2};
  else op["points"] = {{n / 5, n / 2}, {n / 2, 2 * n / 5}, {4 * n / 5, n / 2}};
  if (t.name == "free_crest") op["height"] = 100;  // gradient-only tools have no ground to measure from
  if (t.name == "ravine") op["depth"] = 60;
  return op;
}

void check_sign(const Heightfield& before, const Heightfield& after, const Tool& t, const std::string& where) {
  double with = 0, against = 0;
  for (size_t i = 0; i < before.z.size(); ++i) {
    ASSERT_TRUE(std::isfinite(after.z[i])) << t.name << where;
    const double d = t.sign * (double(after.z[i]) - double(before.z[i]));
    with = std::max(with, d), against = std::max(against, -d);
  }
  EXPECT_GT(with, 10.0) << t.name << where << ": the default stroke should make a landform";
  EXPECT_LE(against, 1.0) << t.name << where << ": a cell moved against the landform's sign";
}

}  // namespace

TEST(LandformStrokes, DefaultStrokesKeepTheirSignOnAFlatBase) {
  const int n = 257;
  const Heightfield base = *parse_flat_spec(fmt::format("flat:{}x{}@30+500", n, n));
  for (const Tool& t : kTools) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"}, {"operations", {default_stroke(t, n)}}});
    const Heightfield& h = s.height();
    check_sign(base, h, t, " on flat");
    // The far field keeps the base's level: the corners are untouched plain.
    for (auto [x, y] : {std::pair{0, 0}, {n - 1, 0}, {0, n - 1}, {n - 1, n - 1}})
      EXPECT_NEAR(h.at(x, y), 500.0, 0.5) << t.name << ": the plain moved at (" << x << ", " << y << ")";
  }
}

TEST(LandformStrokes, DefaultStrokesKeepTheirSignOnARealDem) {
  const int n = 300;
  const Heightfield base = test::n44_window(500, 400, n);
  for (const Tool& t : kTools) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"}, {"operations", {default_stroke(t, n)}}});
    check_sign(base, s.height(), t, " on N44W072");
  }
}

// A river across rolling real hills: its bed runs at most its depth below the lowest ground it
// passes, and nothing it carves (side valleys, texture) goes below that. Before, side valleys took
// the gorge's depth where it crossed a ridge and dug it below their own lower ground, and the
// default depth grew with the stroke's length: these two strokes reached 61 and 76 m, 190 m under
// the lowest ground of the window, against 201 and 203 m now.
TEST(LandformStrokes, DefaultRiverStaysAboveItsBedOnRealHills) {
  const Heightfield base = test::n44_window(300, 300, 300);
  for (const json& pts : {json{{20, 250}, {150, 150}, {285, 200}}, json{{20, 80}, {150, 110}, {285, 80}}}) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"}, {"operations", {{{"op", "river"}, {"points", pts}}}}});
    const Heightfield& h = s.height();
    const double depth = s.log()[0].at("size_m").get<double>();
    float ground = 1e30f, lowest = 1e30f;
    for (size_t i = 0; i < h.z.size(); ++i) {
      if (h.z[i] < base.z[i] - 0.5f) ground = std::min(ground, base.z[i]);
      lowest = std::min(lowest, h.z[i]);
    }
    ASSERT_LT(ground, 1e30f) << "the river carved nothing";
    EXPECT_GE(lowest, ground - depth - 2.0) << pts.dump() << ": depth " << depth << " m below the lowest ground " << ground;
    // The default depth follows the hills' relief, not the 19 km length.
    EXPECT_LT(depth, 100.0) << pts.dump();
  }
}

TEST(LandformStrokes, RelativeCrestSitsItsHeightAboveTheGround) {
  const int n = 240;
  const Heightfield base = test::n44_window(300, 600, n);
  EditSession s(test::device(), base);
  const double cx = base.georef.cell_x, cy = base.georef.cell_y;
  // Vertices on cell centres (metres), where the crest line passes exactly.
  const std::vector<std::pair<int, int>> v = {{50, 120}, {120, 100}, {190, 130}};
  json pts = json::array();
  for (auto [x, y] : v) pts.push_back({x * cx, y * cy});
  s.apply({{"operations", {{{"op", "crest"}, {"points", pts}, {"height", 120}}}}});
  const Heightfield& h = s.height();
  const auto [x, y] = v[1];
  EXPECT_NEAR(h.at(x, y) - base.at(x, y), 120.0, 1.0);
  EXPECT_FALSE(s.log()[0].contains("warnings")) << s.log()[0].dump();
}

TEST(LandformStrokes, MountainRangeHeightsPerVertexAndSeedsAreRepeatable) {
  const Heightfield base = *parse_flat_spec("flat:200x200@20+100");
  auto run = [&](int seed) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"},
             {"operations", {{{"op", "mountain_range"}, {"points", {{30, 100, 300}, {170, 90, 150}}}, {"seed", seed}}}}});
    return s.height();
  };
  const Heightfield a = run(7), b = run(7), c = run(8);
  EXPECT_EQ(a.z, b.z) << "the same seed gives the same range";
  EXPECT_NE(a.z, c.z);
  // The western end carries the 300 m summit, the eastern one 150 m.
  float west = 0, east = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) (x < 100 ? west : east) = std::max(x < 100 ? west : east, a.at(x, y) - 100.0f);
  EXPECT_GT(west, east);
  EXPECT_LT(west, 300 * 1.6);
}

TEST(LandformStrokes, ConstraintsCuttingTheTerrainWarn) {
  const Heightfield base = test::n44_window(300, 600, 200);
  float lo = 1e30f;
  for (float z : base.z) lo = std::min(lo, z);
  EditSession s(test::device(), base);
  s.apply({{"units", "cells"},
           {"operations", {{{"op", "crest"}, {"points", {{40, 100}, {160, 100}}}, {"elevation", lo}, {"height", 50}}}}});
  const auto w = s.warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("cut into the terrain"), std::string::npos) << w[0];
  EXPECT_GT(s.log()[0]["constraint_cut_m"].get<double>(), 10.0);
}

namespace {

// Slopes (degrees) of the terrain at the cells where `mask` holds, by central differences.
std::vector<double> slopes_where(const Heightfield& h, const std::function<bool(int, int)>& mask) {
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  std::vector<double> out;
  for (int y = 1; y + 1 < h.height; ++y)
    for (int x = 1; x + 1 < h.width; ++x)
      if (mask(x, y)) {
        const double gx = (h.at(x + 1, y) - h.at(x - 1, y)) / (2 * cx), gy = (h.at(x, y + 1) - h.at(x, y - 1)) / (2 * cy);
        out.push_back(std::atan(std::hypot(gx, gy)) * 180 / M_PI);
      }
  return out;
}
double quantile(std::vector<double> v, double q) {
  const size_t i = std::min(v.size() - 1, size_t(q * double(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}

}  // namespace

// A long stroke drawn across hills makes a landform at the hills' scale: a default crest no taller
// than half their relief, with flanks about as steep as the ground's own steep slopes; a default
// river runs from the higher end of the ground under it (drawn either way, the same valley), and
// where its bed must cut through a rise the valley widens with the gorge so its walls keep their
// slope instead of making a slot.
TEST(LandformStrokes, DefaultStrokesAcrossHillsMatchTheHills) {
  const int n = 300;
  const Heightfield base = test::n44_window(500, 400, n);
  std::vector<double> z(base.z.begin(), base.z.end());
  const double relief = quantile(z, 0.95) - quantile(z, 0.05);
  const double steep = std::max(20.0, quantile(slopes_where(base, [](int, int) { return true; }), 0.9));
  // West to east the ground rises from 255 m to 840 m and crosses a ridge of about 900 m on the way.
  const json west_to_east = {{15, 150}, {150, 120}, {285, 150}};
  const json east_to_west = {{285, 150}, {150, 120}, {15, 150}};
  for (const std::string tool : {"crest", "river"}) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"}, {"operations", {{{"op", tool}, {"points", west_to_east}}}}});
    const Heightfield& h = s.height();
    double peak = 0;
    for (size_t i = 0; i < h.z.size(); ++i) peak = std::max(peak, std::abs(double(h.z[i]) - base.z[i]));
    const auto sl = slopes_where(h, [&](int x, int y) { return std::abs(h.at(x, y) - base.at(x, y)) > 0.1 * peak; });
    const double p50 = quantile(sl, 0.5), p90 = quantile(sl, 0.9);
    SCOPED_TRACE(fmt::format("{}: relief {:.0f} m, steep ground {:.1f} deg, peak change {:.0f} m, slopes p50 {:.1f} p90 {:.1f} deg",
                             tool, relief, steep, peak, p50, p90));
    if (tool == "crest") {
      EXPECT_LT(peak, 0.5 * relief);
      EXPECT_LT(p50, steep + 8);
    } else {
      EXPECT_LT(p90, steep + 10);
      EditSession r(test::device(), base);
      r.apply({{"units", "cells"}, {"operations", {{{"op", tool}, {"points", east_to_west}}}}});
      EXPECT_EQ(r.height().z, h.z) << "a river drawn from its low end is the same river";
    }
  }
}
