// SPDX-License-Identifier: Apache-2.0
// Erosion T9 on the bundled SRTM data, with a small independent reference for the
// geomorphic measures, and the `terracl erode` / `terracl bench erode` commands run as a user would.
#include "test_helpers.hpp"

#include <terracl/analysis.hpp>
#include <terracl/erosion.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>

using namespace terracl;

namespace {

double gini(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const double n = double(v.size());
  double weighted = 0, sum = 0;
  for (size_t i = 0; i < v.size(); ++i) weighted += (i + 1) * v[i], sum += v[i];
  return 2 * weighted / (n * sum) - (n + 1) / n;
}

double mean_abs_laplacian(const Heightfield& h) {
  const double lx2 = h.georef.cell_x * h.georef.cell_x, ly2 = h.georef.cell_y * h.georef.cell_y;
  double s = 0;
  int count = 0;
  for (int y = 1; y + 1 < h.height; ++y)
    for (int x = 1; x + 1 < h.width; ++x) {
      const double c = h.at(x, y);
      s += std::fabs((h.at(x - 1, y) + h.at(x + 1, y) - 2 * c) / lx2 + (h.at(x, y - 1) + h.at(x, y + 1) - 2 * c) / ly2);
      ++count;
    }
  return s / count;
}

std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    for (size_t k = i; k <= j; ++k) r[idx[k]] = 0.5 * (i + j);  // ties share their mean rank
    i = j + 1;
  }
  return r;
}

// Spearman rank correlation; 0 when one side is constant.
double spearman(const std::vector<double>& a, const std::vector<double>& b) {
  const auto ra = ranks(a), rb = ranks(b);
  const double n = double(a.size());
  const double ma = std::accumulate(ra.begin(), ra.end(), 0.0) / n, mb = std::accumulate(rb.begin(), rb.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < ra.size(); ++i)
    sab += (ra[i] - ma) * (rb[i] - mb), saa += (ra[i] - ma) * (ra[i] - ma), sbb += (rb[i] - mb) * (rb[i] - mb);
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

struct Measures {
  double gini_before, gini_after, lap_ratio, rho, rho_abs;  // rho_abs: Spearman(|change|, log A0)
};

Measures measure(const Heightfield& before, const Heightfield& after) {
  const auto a0 = test::d8_area(before), a1 = test::d8_area(after);
  std::vector<double> depth(before.size()), change(before.size()), log_area(before.size());
  for (size_t i = 0; i < depth.size(); ++i)
    depth[i] = double(before.z[i]) - after.z[i], change[i] = std::fabs(depth[i]), log_area[i] = std::log(a0[i]);
  return {gini(a0), gini(a1), mean_abs_laplacian(after) / mean_abs_laplacian(before), spearman(depth, log_area),
          spearman(change, log_area)};
}

}  // namespace

TEST(ErosionReference, MeasuresOnKnownAnswers) {
  // D8 on a plane tilted to the east: every row drains into its last column.
  Heightfield plane(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) plane.at(x, y) = float(10 - x);
  const auto a = test::d8_area(plane);
  EXPECT_EQ(a[4], 5.0);
  EXPECT_EQ(a[0], 1.0);
  EXPECT_NEAR(gini({1, 1, 1, 1}), 0.0, 1e-12);
  EXPECT_NEAR(gini({3, 1, 7, 2, 9}), terracl::analysis::gini({3, 1, 7, 2, 9}), 1e-12) << "agrees with the analysis module";
  EXPECT_NEAR(gini({0, 0, 0, 1}), 0.75, 1e-12);
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {10, 20, 25, 100}), 1.0, 1e-12);
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0, 1e-12);
  EXPECT_EQ(spearman({1, 1, 1}, {1, 2, 3}), 0.0);
  Heightfield bowl(5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) bowl.at(x, y) = float((x - 2) * (x - 2) + (y - 2) * (y - 2));
  EXPECT_NEAR(mean_abs_laplacian(bowl), 4.0, 1e-12);
}

// T9: a default run on the bundled SRTM crop (Presidential Range, from data/dem/N44W072.hgt) carves
// channels; a thermal-only run does none of it.
TEST(Erosion, T9DefaultRunCarvesChannelsOnSrtm) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  // The carving by the flow, before the suspended load settles in the closed box's lakes at the end
  // (settling fills them flat, which splits this test's unfilled D8 flow; the filled-surface Gini
  // below rises with settling too: 0.922 -> 0.929).
  ErosionParams p = ErosionParams::defaults();
  p.settle = false;
  const Heightfield eroded = erode(test::device(), dem, p, 400);
  const Measures m = measure(dem, eroded);
  std::printf("T9 default: Gini %.4f -> %.4f, mean |Laplacian| x%.2f, Spearman(depth, log A0) %.3f, "
              "Spearman(|change|, log A0) %.3f\n",
              m.gini_before, m.gini_after, m.lap_ratio, m.rho, m.rho_abs);
  // Recalibrated for the issue-15 defaults (a third of the rain, bed diffusion 2 m^2/s, open border):
  // they carve less and smooth the one-cell roughness the old ones added (old: Gini 0.778 -> 0.804,
  // |Laplacian| x2.37, Spearman 0.342; new: 0.778 -> 0.821, x1.15, 0.237). Flow still concentrates
  // and erosion still follows drainage area, which the thermal-only run below does not do.
  // The channel diffusion (K_q = 1, issue 15's "several cells wide at 10 m") rounds the channels
  // too: Gini 0.778 -> 0.867 (more concentrated flow), mean |Laplacian| x0.94 (wider channels are
  // smoother at the cell scale), Spearman 0.160 (the banks of the widened channels erode too). The
  // thermal-only run below goes the other way on all three (0.743, x0.43, -0.47).
  // The ribbon fix (undamped pipes, evaporation 0.002, pick-up 0.008) keeps all three: 0.778 ->
  // 0.839, x0.97, Spearman 0.125 (the faster water carves the trunk valleys as well as the gullies).
  EXPECT_GT(m.gini_after, m.gini_before + 0.02);
  EXPECT_GE(m.lap_ratio, 0.85);
  // Since "Does it read as nature" (docs/erosion.md) the capacity follows the slope along the flow
  // and a critical shear: gullies cut the slopes where the flow gathers while the low trunk floors
  // aggrade, so depth no longer rises with log area over all cells (Spearman 0.125 -> -0.21). What
  // must hold is that the change is where water gathers: cells draining >= 20 cells change on
  // average more than 1.5 times as much as cells draining < 3 (3.29 m against 1.83 m: on this raw
  // SRTM3 crop the new gullies start in cells that drain < 3 cells on the input).
  {
    const auto a0 = test::d8_area(dem);
    double hill = 0, chan = 0;
    int nh = 0, nc = 0;
    for (size_t i = 0; i < dem.size(); ++i) {
      const double c = std::fabs(double(eroded.z[i]) - dem.z[i]);
      if (a0[i] < 3) hill += c, ++nh;
      if (a0[i] >= 20) chan += c, ++nc;
    }
    std::printf("T9 default: mean |change| %.3f m where the input drains < 3 cells, %.3f m where >= 20\n",
                hill / std::max(1, nh), chan / std::max(1, nc));
    EXPECT_GT(chan / std::max(1, nc), 1.5 * hill / std::max(1, nh));
  }
  // The analysis module routes D8 on the depression-filled surface instead (every cell drains to
  // the border): an independent routing. With the old defaults its Gini rose (0.922 -> 0.933);
  // with the new ones it stays within 0.005 (0.922 -> 0.918): the diffusion rounds the small
  // channels that concentrated flow on the filled surface. Measured here so that a change shows.
  const double g0 = terracl::analysis::gini(analysis::d8_flow(dem).cells), g1 = terracl::analysis::gini(analysis::d8_flow(eroded).cells);
  std::printf("T9 default, filled-surface D8 (analysis module): Gini %.4f -> %.4f\n", g0, g1);
  // 0.922 -> 0.911 since the trunk floors aggrade (see above), which spreads their filled-surface D8.
  EXPECT_NEAR(g1, g0, 0.015);

  // Thermal only, with a talus low enough (10 deg) that it really moves material on this terrain.
  ErosionParams thermal = p;
  thermal.thermal_only = true;
  thermal.talus_deg = 10.0;
  const Heightfield relaxed = erode(test::device(), dem, thermal, 400);
  double moved = 0;
  for (size_t i = 0; i < dem.size(); ++i) moved = std::max(moved, double(std::fabs(relaxed.z[i] - dem.z[i])));
  EXPECT_GT(moved, 1.0) << "the thermal-only run must do something";
  const Measures t = measure(dem, relaxed);
  std::printf("T9 thermal only: Gini %.4f -> %.4f, mean |Laplacian| x%.2f, Spearman %.3f\n", t.gini_before,
              t.gini_after, t.lap_ratio, t.rho);
  EXPECT_LE(t.gini_after, t.gini_before + 0.005);
  EXPECT_LT(t.lap_ratio, 0.8);
  EXPECT_LT(t.rho, 0.0);
}

TEST(ErosionCli, ErodeWritesOutputsAndProvenance) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  auto r = test::run_cli(fmt::format("erode {} -o {} --steps 30 --water {} --sediment {} --delta {} -q", in,
                                     tmp.path("out.tif"), tmp.path("w.exr"), tmp.path("s.exr"), tmp.path("d.exr")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield out = read_heightfield(tmp.path("out.tif"));
  const Heightfield w = read_heightfield(tmp.path("w.exr"));
  const Heightfield d = read_heightfield(tmp.path("d.exr"));
  const Heightfield src = read_heightfield(in);
  ASSERT_EQ(out.width, 128);
  ASSERT_EQ(w.height, 96);
  EXPECT_GT(*std::max_element(w.z.begin(), w.z.end()), 0.0f);
  for (size_t i = 0; i < out.size(); ++i) ASSERT_NEAR(d.z[i], out.z[i] - src.z[i], 1e-3) << i;
  EXPECT_TRUE(w.metadata.count("terracl:erode")) << "the run summary travels with the outputs";
  // --time converts to steps; a unit is accepted.
  r = test::run_cli(fmt::format("erode {} -o {} --time 0.2min --rain \"20000 mm/h\" -q", in, tmp.path("t.tif")));
  EXPECT_EQ(r.exit_code, 0) << r.out;
}

TEST(ErosionCli, BadArgumentsAreClearErrors) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  auto r = test::run_cli(fmt::format("erode {} -o {} --boundary sideways", in, tmp.path("o.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("closed|open"), std::string::npos) << r.out;
  r = test::run_cli(fmt::format("erode {} -o {} --rain 5kg", in, tmp.path("o.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("rain"), std::string::npos) << r.out;
  r = test::run_cli(fmt::format("erode {} -o {} --dissolve -1", in, tmp.path("o.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("dissolve"), std::string::npos) << r.out;
  std::ofstream(tmp.path("c.json")) << R"({"points": [{"x": 500, "y": 2}]})";
  r = test::run_cli(fmt::format("erode {} -o {} --keep-constraints {}", in, tmp.path("o.tif"), tmp.path("c.json")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("/points/0"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("o.tif"))) << "no output after a failure";
  // Nodata cells are rejected with a hint, never eroded into NaN.
  Heightfield holes = read_heightfield(in);
  holes.at(5, 5) = NAN;
  write_heightfield(holes, tmp.path("holes.exr"));
  r = test::run_cli(fmt::format("erode {} -o {} --steps 5", tmp.path("holes.exr"), tmp.path("o.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("fill-nodata"), std::string::npos) << r.out;
  r = test::run_cli(fmt::format("erode {} -o {} --steps 5 --fill-nodata -q", tmp.path("holes.exr"), tmp.path("o.tif")));
  EXPECT_EQ(r.exit_code, 0) << r.out;
}

TEST(ErosionCli, RegionBrushAndKeptConstraints) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const Heightfield src = read_heightfield(in);
  // Brush: the left half painted white, as a 16-bit PNG.
  Heightfield mask(src.width, src.height, 0.0f);
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < src.width / 2; ++x) mask.at(x, y) = 1.0f;
  WriteOptions wo;
  wo.zmin = 0.0;
  wo.zmax = 1.0;
  write_heightfield(mask, tmp.path("mask.png"), wo);
  // Constraints: a polygon and a point on the painted side stay fixed.
  std::ofstream(tmp.path("c.json")) << R"({"points": [{"x": 20, "y": 70, "z": 500}],
      "polygons": [{"points": [[10, 10], [40, 10], [40, 30], [10, 30]]}]})";
  auto r = test::run_cli(fmt::format("erode {} -o {} --steps 150 --region {} --region-feather 2 --keep-constraints {} -q",
                                     in, tmp.path("o.tif"), tmp.path("mask.png"), tmp.path("c.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield out = read_heightfield(tmp.path("o.tif"));
  double changed_inside = 0;
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < src.width; ++x) {
      const bool fixed = (x >= 11 && x <= 39 && y >= 11 && y <= 29) || (x == 20 && y == 70);
      if (x >= src.width / 2 + 8 || fixed) {
        ASSERT_EQ(out.at(x, y), src.at(x, y)) << "cell " << x << "," << y << " must not change";
      } else if (x < src.width / 2 - 8) {
        changed_inside = std::max(changed_inside, double(std::fabs(out.at(x, y) - src.at(x, y))));
      }
    }
  EXPECT_GT(changed_inside, 1.0) << "the painted side must be eroded";
  // The brush edge is smooth: near the edge cells change, but less than well inside.
}

TEST(ErosionCli, BenchPrintsStepsPerSecond) {
  auto r = test::run_cli("bench erode --size 64 --repeats 3");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("ms/step"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("steps/s"), std::string::npos) << r.out;
}

TEST(ErosionBrush, RegionWeightHasSmoothEdge) {
  test::TempDir tmp;
  Heightfield grid(40, 10, 0.0f);
  Heightfield mask(20, 5, 0.0f);  // half the size: resampled bilinearly
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 10; ++x) mask.at(x, y) = 1.0f;
  WriteOptions wo;
  wo.zmin = 0.0;
  wo.zmax = 1.0;
  write_heightfield(mask, tmp.path("m.png"), wo);
  const auto w = read_region_weight(tmp.path("m.png"), grid, 2.0);
  ASSERT_EQ(w.size(), grid.size());
  const int y = 5;
  EXPECT_NEAR(w[size_t(y) * 40 + 0], 1.0, 1e-3);
  EXPECT_NEAR(w[size_t(y) * 40 + 39], 0.0, 1e-3);
  for (int x = 1; x < 40; ++x) EXPECT_LE(w[size_t(y) * 40 + x], w[size_t(y) * 40 + x - 1] + 1e-6f) << x;
  int partial = 0;
  for (int x = 0; x < 40; ++x) partial += w[size_t(y) * 40 + x] > 0.05f && w[size_t(y) * 40 + x] < 0.95f;
  EXPECT_GE(partial, 4) << "a feathered edge spans several cells";
  // Without feathering the edge is as sharp as the (resampled) mask.
  const auto sharp = read_region_weight(tmp.path("m.png"), grid, 0.0);
  partial = 0;
  for (int x = 0; x < 40; ++x) partial += sharp[size_t(y) * 40 + x] > 0.05f && sharp[size_t(y) * 40 + x] < 0.95f;
  EXPECT_LE(partial, 2);
}

TEST(ErosionBrush, ConstraintsInPixelsAndGeoreferencedAgree) {
  test::TempDir tmp;
  Heightfield grid(30, 20, 0.0f);
  grid.georef.geotransform = {1000.0, 10.0, 0.0, 5000.0, 0.0, -10.0};
  grid.georef.has_geotransform = true;
  std::ofstream(tmp.path("px.json")) << R"({"polygons": [{"points": [[3, 4], [12, 4], [12, 9], [3, 9]]}],
                                            "polylines": [{"points": [[20, 2], [20, 15]], "width": 3}],
                                            "points": [[25, 18]]})";
  // Cell (c, r) has its centre at x = 1000 + 10 (c + 0.5), y = 5000 - 10 (r + 0.5).
  std::ofstream(tmp.path("geo.json")) << R"({"units": "georeferenced",
      "polygons": [{"points": [[1035, 4955], [1125, 4955], [1125, 4905], [1035, 4905]]}],
      "polylines": [{"points": [[1205, 4975], [1205, 4845]], "width": 3}],
      "points": [{"x": 1255, "y": 4815, "z": 7}]})";
  const auto a = read_fixed_cells(tmp.path("px.json"), grid);
  const auto b = read_fixed_cells(tmp.path("geo.json"), grid);
  EXPECT_EQ(a, b);
  EXPECT_TRUE(a[size_t(6) * 30 + 7]) << "inside the polygon";
  EXPECT_FALSE(a[size_t(15) * 30 + 5]) << "outside everything";
  EXPECT_TRUE(a[size_t(10) * 30 + 21]) << "within the polyline's width";
  EXPECT_FALSE(a[size_t(10) * 30 + 23]);
  EXPECT_TRUE(a[size_t(18) * 30 + 25]) << "the point";
  std::ofstream(tmp.path("bad.json")) << R"({"polygons": [{"points": [[1, 1], [2, "x"], [3, 3]]}]})";
  try {
    read_fixed_cells(tmp.path("bad.json"), grid);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/polygons/0/points/1"), std::string::npos) << e.what();
  }
}
