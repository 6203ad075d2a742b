// SPDX-License-Identifier: Apache-2.0
// Edit operations end to end with the reconstruction, against analytic expectations.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>

using namespace terracl;
using json = nlohmann::json;

namespace {

Heightfield flat(int w, int h, double cell) { return *parse_flat_spec(fmt::format("flat:{}x{}@{}", w, h, cell)); }

Heightfield run(const Heightfield& base, const json& script, json* report = nullptr) {
  EditSession s(test::device(), base);
  s.apply(script);
  Heightfield h = s.height();
  if (report) *report = s.report();
  return h;
}

}  // namespace

TEST(Edit, FlatSpecParses) {
  const Heightfield f = flat(33, 17, 2.5);
  EXPECT_EQ(f.width, 33);
  EXPECT_EQ(f.height, 17);
  EXPECT_DOUBLE_EQ(f.georef.cell_x, 2.5);
  EXPECT_FALSE(parse_flat_spec("terrain.tif").has_value());
  EXPECT_THROW(parse_flat_spec("flat:10by10"), UsageError);
  EXPECT_THROW(parse_flat_spec("flat:1x10"), UsageError);
}

// Figure 16: where hard and soft constraints disagree, the hard ones win, to the bit.
TEST(Edit, HardConstraintsWinOverConflictingGradients) {
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "crest"}, {"points", {{8, 32}, {56, 32}}}, {"elevation", 100}, {"radius", 10}, {"height", 30}},
                         {{"op", "free_crest"}, {"points", {{32, 4}, {32, 60}}}, {"height", 400}, {"radius", 12}},
                         {{"op", "fault"}, {"points", {{0, 20}, {64, 44}}}, {"throw", -250}, {"radius", 4}},
                         {{"op", "scale_slopes"}, {"center", {32, 32}}, {"radius", 15}, {"factor", 5}}}}};
  const Heightfield h = run(flat(65, 65, 5), script);
  int checked = 0;
  for (int x = 8; x <= 56; ++x) {
    EXPECT_EQ(h.at(x, 32), 100.0f) << "x " << x;
    ++checked;
  }
  EXPECT_EQ(checked, 49);
  // The soft constraints did act elsewhere.
  EXPECT_GT(std::abs(h.at(32, 10) - h.at(10, 10)), 20.0f);
}

TEST(Edit, CrossingFaultsAddUp) {
  // Fault 1 runs south along x = 32: its right (west) side rises by 10 m. Fault 2 runs east along
  // y = 32: its right (south) side rises by 20 m. Both extend past the grid.
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "fault"}, {"points", {{32, -20}, {32, 84}}}, {"throw", 10}, {"radius", 4}},
                         {{"op", "fault"}, {"points", {{-20, 32}, {84, 32}}}, {"throw", 20}, {"radius", 4}}}}};
  const Heightfield h = run(flat(65, 65, 1), script);
  const float tl = h.at(10, 10), tr = h.at(54, 10), bl = h.at(10, 54), br = h.at(54, 54);
  EXPECT_NEAR(tl - tr, 10.0, 0.2);
  EXPECT_NEAR(br - tr, 20.0, 0.2);
  EXPECT_NEAR(bl - tr, 30.0, 0.3);  // both throws: gradient constraints superpose additively
}

TEST(Edit, CrossingCrestsDoNotAdd) {
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "crest"}, {"points", {{8, 32}, {56, 32}}}, {"elevation", 100}, {"radius", 10}, {"height", 40}},
                         {{"op", "crest"}, {"points", {{32, 8}, {32, 56}}}, {"elevation", 100}, {"radius", 10}, {"height", 40}}}}};
  const Heightfield h = run(flat(65, 65, 5), script);
  EXPECT_EQ(h.at(32, 32), 100.0f);
  float mx = -1e9f;
  for (float v : h.z) mx = std::max(mx, v);
  EXPECT_LT(mx, 110.0f);  // elevation constraints replace each other: no 200 m peak at the crossing
}

TEST(Edit, CopyPasteHasNoStepAcrossTheBoundary) {
  Heightfield base = test::smooth_terrain(96, 96, 30.0, 200.0, 5);
  test::TempDir tmp;
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "copy_paste"}, {"source", test::data_path("crops/presidential_128x96.tif")},
                          {"from", {20, 20, 40, 40}}, {"to", {48, 48}}, {"rotate", 30}}}}};
  EditSession s(test::device(), base);
  s.apply(script);
  const Heightfield h = s.height();
  const GradientField g = s.gradient();
  // The pasted footprint: |local| <= 20 cells of the source (same cell size? use the log).
  const Heightfield src = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const double scale_cells = 20 * src.georef.cell_x / base.georef.cell_x;
  const double c = std::cos(-30 * M_PI / 180), sn = std::sin(-30 * M_PI / 180);
  auto inside = [&](int x, int y) {
    const double dx = (x - 48.0), dy = (y - 48.0);
    const double lx = c * dx + sn * dy, ly = -sn * dx + c * dy;
    return std::max(std::abs(lx), std::abs(ly)) <= scale_cells;
  };
  int crossings = 0;
  double worst = 0;
  for (int y = 1; y < 94; ++y)
    for (int x = 1; x < 94; ++x) {
      if (inside(x, y) == inside(x + 1, y)) continue;
      ++crossings;
      double local = 0;  // the steepest slope around the face (edited field and result), the face excluded
      for (int yy = y - 1; yy <= y + 1; ++yy)
        for (int xx = x - 1; xx <= x + 1; ++xx) {
          const size_t o = size_t(yy) * 96 + xx;
          local = std::max({local, double(std::abs(g.gx[o])), double(std::abs(g.gy[o]))});
          // Result faces that do not cross the boundary themselves (a step would not hide there).
          if (inside(xx, yy) == inside(xx, yy + 1))
            local = std::max(local, double(std::abs(h.z[o + 96] - h.z[o])) / base.georef.cell_y);
          if (inside(xx, yy) == inside(xx + 1, yy))
            local = std::max(local, double(std::abs(h.z[o + 1] - h.z[o])) / base.georef.cell_x);
        }
      const double jump = std::abs(h.at(x + 1, y) - h.at(x, y));
      worst = std::max(worst, jump / (local * base.georef.cell_x + 1e-3));
      EXPECT_LE(jump, local * base.georef.cell_x + 0.5) << x << "," << y;
    }
  EXPECT_GT(crossings, 40);
  EXPECT_LT(worst, 1.0);
  EXPECT_GT(s.log()[0]["pasted_faces"].get<int>(), 1000);
}

TEST(Edit, RegularizeLowersTheCurlAndDropsConstraints) {
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "crest"}, {"points", {{10, 20}, {50, 30}}}, {"elevation", 80}, {"radius", 8}},
                         {{"op", "noise"}, {"amplitude", 5}, {"wavelength", 40}, {"orient", {{"angle", 30}, {"strength", 0.9}}}},
                         {{"op", "tensor"}, {"primitives", {{{"shape", "point"}, {"center", {32, 32}}, {"radius", 20}, {"tensor", "closest"}}}}},
                         {{"op", "regularize"}}}}};
  EditSession s(test::device(), flat(64, 64, 10));
  s.apply(script);
  const json& r = s.log()[3];
  EXPECT_GT(r["curl_rms_before"].get<double>(), 1e-4);
  EXPECT_LT(r["curl_rms_after"].get<double>(), 1e-3 * r["curl_rms_before"].get<double>());
  EXPECT_GT(r["dropped_constraints"].get<int>(), 30);
  EXPECT_EQ(s.hard_cells(), 0u);
  // The constrained elevation is kept implicitly after the constraints are gone.
  const Heightfield h = s.solve(false).height.width ? s.height() : s.height();
  EXPECT_NEAR(h.at(10, 20), 80.0, 0.05);
}

TEST(Edit, GradientImageRoundTripWithinQuantisation) {
  GradientField g(37, 23);
  g.georef.cell_x = g.georef.cell_y = 7;
  std::mt19937 rng(9);
  std::normal_distribution<float> nd(0, 0.4f);
  for (size_t i = 0; i < g.size(); ++i) g.gx[i] = nd(rng), g.gy[i] = nd(rng);
  test::TempDir tmp;
  write_gradient_image(g, tmp.path("g.png"));
  const GradientField back = read_gradient_image(tmp.path("g.png"));
  double m = 0;
  for (size_t i = 0; i < g.size(); ++i) m = std::max({m, double(std::abs(g.gx[i])), double(std::abs(g.gy[i]))});
  const double bound = m / 32768.0;  // m / 2^(p-1), p = 16
  ASSERT_EQ(back.width, 37);
  EXPECT_DOUBLE_EQ(back.georef.cell_x, 7);
  double worst = 0;
  for (size_t i = 0; i < g.size(); ++i)
    worst = std::max({worst, std::abs(double(back.gx[i]) - g.gx[i]), std::abs(double(back.gy[i]) - g.gy[i])});
  EXPECT_LE(worst, bound);
  EXPECT_GT(worst, 0.0);
  EXPECT_THROW(read_gradient_image(tmp.path("missing.png")), Error);
}

TEST(Edit, WarmStartedResolveNeedsNoMoreCyclesThanCold) {
  EditSession s(test::device(), flat(129, 129, 10));
  s.apply(json{{"units", "cells"},
               {"operations",
                {{{"op", "mountain_range"}, {"points", {{20, 40}, {100, 60}}}, {"radius", 25}, {"height", 300}},
                 {{"op", "river"}, {"points", {{0, 110}, {128, 100}}}, {"elevation", 0}, {"radius", 10}}}}});
  s.solve(false);
  s.apply(json{{"units", "cells"}, {"operations", {{{"op", "ravine"}, {"points", {{60, 70}, {70, 100}}}, {"depth", 20}, {"radius", 6}}}}});
  const int warm = s.solve(true).cycles;
  const int cold = s.solve(false).cycles;
  EXPECT_LE(warm, cold);
  EXPECT_GE(cold, 1);
}

// Issue 19 point 1: the operations are queued without a wait between them, their parameters
// written (non-blocking) into one buffer that grows mid-script (more than 64 primitives, more than
// 1024 vertices). Waiting after every operation (TERRACL_PHASES=1) must give the same bits.
TEST(Edit, QueuedOperationsGiveTheBitsOfWaitedOnes) {
  json many = json::array();
  for (int i = 0; i < 80; ++i)
    many.push_back({{"shape", "point"}, {"center", {10 + (i * 37) % 110, 10 + (i * 53) % 110}}, {"radius", 6}, {"angle", i * 9}});
  json wiggle = json::array();
  for (int i = 0; i < 1500; ++i) wiggle.push_back({4 + 120.0 * i / 1499, 64 + 20 * std::sin(i * 0.05)});
  json ops = json::array();
  ops.push_back({{"op", "mountain_range"}, {"points", {{20, 40}, {100, 60}}}, {"radius", 25}, {"height", 300}});
  ops.push_back({{"op", "tensor"}, {"primitives", many}});
  ops.push_back({{"op", "crest"}, {"points", {{30, 90}, {90, 100}}}, {"elevation", 200}, {"radius", 12}, {"height", 80}});
  json line = {{"shape", "polyline"}, {"radius", 8}, {"tensor", "tangent"}};
  line["points"] = wiggle;
  ops.push_back({{"op", "tensor"}, {"primitives", json::array({line})}});
  ops.push_back({{"op", "noise"}, {"center", {64, 64}}, {"radius", 40}, {"amplitude", 10}, {"wavelength", 20}});
  ops.push_back({{"op", "fault"}, {"points", {{10, 10}, {120, 70}}}, {"throw", 30}, {"radius", 8}});
  ops.push_back({{"op", "scale_slopes"}, {"center", {50, 50}}, {"radius", 30}, {"falloff", 10}, {"factor", 1.4}});
  const json script = {{"units", "cells"}, {"seed", 3}, {"operations", ops}};
  auto field = [&](bool wait) {
    if (wait) setenv("TERRACL_PHASES", "1", 1);
    EditSession s(test::device(), flat(129, 129, 10));
    s.apply(script);
    unsetenv("TERRACL_PHASES");
    return s.gradient();
  };
  const GradientField queued = field(false), waited = field(true);
  ASSERT_EQ(queued.gx.size(), waited.gx.size());
  EXPECT_EQ(0, std::memcmp(queued.gx.data(), waited.gx.data(), queued.gx.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(queued.gy.data(), waited.gy.data(), queued.gy.size() * sizeof(float)));
  double moved = 0;  // the operations did something
  for (size_t i = 0; i < queued.gx.size(); ++i) moved += std::abs(queued.gx[i]);
  EXPECT_GT(moved, 1.0);
}

TEST(Edit, FreezeKeepsTheCurrentElevation) {
  Heightfield base = test::smooth_terrain(48, 48, 10.0, 100.0, 2);
  EditSession s(test::device(), base);
  s.apply(json{{"units", "cells"},
               {"operations",
                {{{"op", "freeze"}, {"center", {24, 24}}, {"radius", 8}},
                 {{"op", "scale_slopes"}, {"center", {24, 24}}, {"radius", 20}, {"factor", 0}}}}});
  const Heightfield& h = s.height();
  EXPECT_EQ(h.at(24, 24), base.at(24, 24));
  EXPECT_EQ(h.at(30, 24), base.at(30, 24));
  EXPECT_GT(s.hard_cells(), 150u);
}

TEST(Edit, MesaPlateauAndRiverElevations) {
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "mesa"}, {"center", {20, 20}}, {"radius", 6}, {"elevation", 300}, {"height", 100}},
                         {{"op", "river"}, {"points", {{0, 50, 40}, {63, 45, 10}}}, {"radius", 8}, {"bank_height", 5}},
                         {{"op", "cliff"}, {"points", {{40, 5}, {60, 25}}}, {"elevation", 150}, {"height", 60}, {"radius", 5}}}}};
  const Heightfield h = run(flat(64, 64, 10), script);
  EXPECT_EQ(h.at(26, 20), 300.0f);             // the rim ring is hard
  EXPECT_NEAR(h.at(20, 20), 300.0, 0.1 * 100);  // the cap is free, with detail of ~0.03 height
  EXPECT_NEAR(h.at(0, 50), 40.0, 1e-4);
  EXPECT_NEAR(h.at(63, 45), 10.0, 1e-4);
  EXPECT_EQ(h.at(50, 15), 150.0f);
  EXPECT_LT(h.at(20, 34), 260.0f);  // the rim drops away from the plateau
}

TEST(Edit, FitToContoursRidgesAndRivers) {
  const json script = {{"units", "cells"},
                       {"operations",
                        {{{"op", "fit"},
                          {"contours", {{{"points", {{5, 5}, {58, 5}, {58, 58}, {5, 58}}}, {"elevation", 10}, {"closed", true}}}},
                          {"ridges", {{{"points", {{15, 32, 120}, {48, 32, 150}}}}}},
                          {"rivers", {{{"points", {{32, 40, 30}, {32, 56, 12}}}}}},
                          {"noise", {{"amplitude", 5}, {"fade", 80}}}}}}};
  const Heightfield h = run(test::smooth_terrain(64, 64, 10.0, 300.0, 3), script);
  EXPECT_NEAR(h.at(5, 20), 10.0, 1e-4);
  EXPECT_NEAR(h.at(15, 32), 120.0, 1e-4);
  EXPECT_NEAR(h.at(48, 32), 150.0, 1e-4);
  EXPECT_NEAR(h.at(32, 56), 12.0, 1e-4);
  // Inside the contour the terrain stays between the constraints (the base relief was cleared).
  EXPECT_GT(h.at(30, 20), 10.0f);
  EXPECT_LT(h.at(30, 20), 150.0f);
}

TEST(Edit, StageRunsAScript) {
  const StageInfo* st = StageRegistry::instance().find("edit");
  ASSERT_NE(st, nullptr);
  test::TempDir tmp;
  write_text_file_atomic(tmp.path("s.json"),
                         json{{"operations", {{{"op", "crest"}, {"points", {{10, 10}, {100, 100}}}, {"elevation", 50}, {"radius", 20}}}}}.dump());
  StageData data;
  data.height = flat(24, 24, 5);
  data.current = DataKind::Heightfield;
  const json opts = resolve_options(*st, json{{"script", tmp.path("s.json")}}, "/0");
  StageContext ctx{data, opts, []() -> Device& { return test::device(); }, nullptr, "edit", {}};
  st->run(ctx);
  EXPECT_EQ(data.height->at(10, 10), 50.0f);  // (50 m, 50 m) is cell (10, 10) at 5 m cells
}

// `terracl sketch --json` files (analysis module) feed `fit` directly: pixel coordinates of the
// sketch's own grid, extra keys ignored, peaks become point constraints.
TEST(Edit, FitReadsASketchFile) {
  test::TempDir tmp;
  const json sketch = {{"format", "terracl-sketch"}, {"version", 1}, {"width", 33}, {"height", 33},
                       {"cell_x_m", 90.0}, {"cell_y_m", 90.0},
                       {"rivers", {{{"points", {{2, 30, 15}, {16, 28, 10}, {30, 31, 5}}}, {"drainage_area_m2", 1e6}}}},
                       {"ridges", {{{"points", {{4, 6, 200}, {28, 8, 260}}}, {"drainage_area_m2", 5e5}}}},
                       {"peaks", {{{"x", 16}, {"y", 16}, {"z", 300.0}, {"relief_m", 200}}}},
                       {"basins", json::array()}};
  write_text_file_atomic(tmp.path("sketch.json"), sketch.dump());
  // A 65x65 grid: the sketch's pixel (x, y) lands on cell (2x, 2y).
  const Heightfield h = run(flat(65, 65, 10), json{{"operations", {{{"op", "fit"}, {"file", tmp.path("sketch.json")}}}}});
  EXPECT_NEAR(h.at(32, 32), 300.0, 1e-4);
  EXPECT_NEAR(h.at(8, 12), 200.0, 1e-4);
  EXPECT_NEAR(h.at(60, 62), 5.0, 1e-4);
  EXPECT_GT(h.at(32, 40), 5.0f);
  EXPECT_LT(h.at(32, 40), 300.0f);
}

// Operations share scratch buffers (the mask also holds profile potentials): a masked noise layer
// must not read what an earlier operation left just outside its own box (it did, and the canyon
// example grew a 150 m step along the noise box's edge). Layers add linearly, so the noise's
// contribution must not depend on what ran before it.
TEST(Edit, MaskedNoiseIgnoresScratchLeftByEarlierOperations) {
  const Heightfield base = flat(96, 64, 10);
  const json ravine = {{"op", "ravine"}, {"points", {{2, 30}, {94, 34}}}, {"depth", 40}, {"radius", 20}};
  const json noise = {{"op", "noise"}, {"center", {30, 32}}, {"radius", 12}, {"falloff", 6}, {"amplitude", 10},
                      {"wavelength", 8}, {"type", "ridged"}, {"seed", 9}, {"orient", {{"angle", 0}, {"strength", 0.7}}}};
  auto field = [&](std::vector<json> ops) {
    EditSession s(test::device(), base);
    s.apply({{"units", "cells"}, {"seed", 5}, {"operations", ops}});
    return s.gradient();
  };
  const GradientField both = field({ravine, noise}), r = field({ravine}), n = field({noise}), none = field({});
  double worst = 0, scale = 0;
  for (size_t i = 0; i < both.size(); ++i) {
    const double dn = double(n.gx[i]) - none.gx[i], dnb = double(both.gx[i]) - r.gx[i];
    worst = std::max(worst, std::abs(dnb - dn));
    scale = std::max(scale, std::abs(dn));
    worst = std::max(worst, std::abs((double(both.gy[i]) - r.gy[i]) - (double(n.gy[i]) - none.gy[i])));
  }
  EXPECT_GT(scale, 0.05);
  EXPECT_LT(worst, 1e-5 * scale + 1e-6);
}
