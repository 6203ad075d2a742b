// SPDX-License-Identifier: Apache-2.0
// Known-answer tests for depression filling, breaching and flow routing.
#include <cmath>
#include <random>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include "test_helpers.hpp"

using namespace terracl;
using namespace terracl::analysis;

namespace {

Heightfield grid(int w, int h, double cell) {
  Heightfield g(w, h, 0.f);
  g.georef.cell_x = g.georef.cell_y = cell;
  return g;
}

/// Follows D8 directions from cell i; returns the number of steps to an outlet, -1 on a cycle.
int steps_to_outlet(const D8Result& r, size_t i) {
  for (int s = 0; s <= r.width * r.height; ++s) {
    const uint8_t d = r.dir[i];
    if (d == kOutlet) return s;
    if (d >= 8) return -1;
    i = size_t(ptrdiff_t(i) + ptrdiff_t(kDy[d]) * r.width + kDx[d]);
  }
  return -1;
}

}  // namespace

TEST(AnalysisPlane, TiltedPlaneHasNoDepressionsAndColumnAccumulation) {
  // Descends to the south by 2 m per 10 m cell: every cell drains straight south.
  Heightfield h = grid(20, 15, 10.0);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) h.at(x, y) = float(100 - 2 * y);
  const FillResult f = priority_flood_fill(h);
  EXPECT_EQ(f.cells_raised, 0u);
  EXPECT_EQ(f.volume_m3, 0.0);
  const FillResult fe = priority_flood_fill(h, true);
  EXPECT_EQ(fe.cells_raised, 0u);
  const BreachResult b = breach_depressions(h);
  EXPECT_EQ(b.cells_lowered, 0u);
  EXPECT_EQ(b.volume_m3, 0.0);
  const D8Result d8 = d8_flow(h);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const size_t i = size_t(y) * h.width + x;
      EXPECT_EQ(d8.cells[i], double(y + 1)) << x << "," << y;  // the cells upslope plus itself
      EXPECT_EQ(d8.dir[i], y == h.height - 1 ? kOutlet : 2) << x << "," << y;
      EXPECT_DOUBLE_EQ(d8.area_m2(i), 100.0 * (y + 1));
    }
  EXPECT_EQ(d8.outflow_cells, double(h.size()));
  const DinfResult di = dinf_flow(h);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) EXPECT_NEAR(di.cells[size_t(y) * h.width + x], y + 1, 1e-9);
  EXPECT_NEAR(di.outflow_cells, double(h.size()), 1e-9);
}

TEST(AnalysisDepressions, BoxPitFillVolumeAndBreachChannel) {
  // Flat 100 m plain with a 3 x 3 box pit 5 m deep in the middle; 10 m cells.
  Heightfield h = grid(21, 21, 10.0);
  for (float& v : h.z) v = 100.f;
  for (int y = 9; y <= 11; ++y)
    for (int x = 9; x <= 11; ++x) h.at(x, y) = 95.f;
  const FillResult f = priority_flood_fill(h);
  EXPECT_DOUBLE_EQ(f.volume_m3, 9 * 5.0 * 100.0);  // exactly the pit's volume
  EXPECT_EQ(f.cells_raised, 9u);
  EXPECT_DOUBLE_EQ(f.max_depth_m, 5.0);
  for (float v : f.filled.z) EXPECT_EQ(v, 100.f);

  const BreachResult b = breach_depressions(h);
  EXPECT_EQ(b.pits_raised, 0u);  // not a single-cell pit
  // The cheapest way out is a straight channel of 9 cells (8 interior + the border cell).
  EXPECT_EQ(b.cells_lowered, 9u);
  EXPECT_DOUBLE_EQ(b.volume_m3, 9 * 5.0 * 100.0);
  EXPECT_DOUBLE_EQ(b.max_depth_m, 5.0);
  EXPECT_DOUBLE_EQ(b.mean_depth_m, 9 * 5.0 / h.size());
  EXPECT_DOUBLE_EQ(b.mean_depth_breached_m, 5.0);
  // The channel reaches the border, and the breached surface needs no filling at all.
  bool border_cut = false;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x)
      if ((x == 0 || y == 0 || x == h.width - 1 || y == h.height - 1) && b.breached.at(x, y) == 95.f) border_cut = true;
  EXPECT_TRUE(border_cut);
  EXPECT_EQ(priority_flood_fill(b.breached).cells_raised, 0u);
}

TEST(AnalysisDepressions, SingleCellPitIsRaisedNotBreached) {
  Heightfield h = grid(9, 9, 2.0);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 9; ++x) h.at(x, y) = float(10 + x);  // rises to the east
  h.at(4, 4) = 3.f;                                          // 10 m below its lowest neighbour (13)
  const BreachResult b = breach_depressions(h, true);
  EXPECT_EQ(b.pits_raised, 1u);
  EXPECT_DOUBLE_EQ(b.raised_volume_m3, 10.0 * 4.0);
  EXPECT_EQ(b.breached.at(4, 4), 13.f);
  EXPECT_EQ(b.cells_lowered, 0u);
  const BreachResult cut = breach_depressions(h, false);
  EXPECT_EQ(cut.pits_raised, 0u);
  // A channel at 3 m through one cell of each column x = 3..0 (elevations 13, 12, 11, 10).
  EXPECT_EQ(cut.cells_lowered, 4u);
  EXPECT_DOUBLE_EQ(cut.volume_m3, (13 + 12 + 11 + 10 - 4 * 3) * 4.0);
  EXPECT_DOUBLE_EQ(cut.max_depth_m, 10.0);
}

TEST(AnalysisDepressions, ClosedBowlFillsToItsSpillLevel) {
  // Paraboloid bowl: the whole grid drains through the lowest border cells.
  const int n = 31;
  Heightfield h = grid(n, n, 5.0);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h.at(x, y) = float(0.01 * ((x - 15) * (x - 15) + (y - 15) * (y - 15)) * 25.0);
  float spill = INFINITY;
  for (int i = 0; i < n; ++i) spill = std::min({spill, h.at(i, 0), h.at(i, n - 1), h.at(0, i), h.at(n - 1, i)});
  double expected = 0;
  size_t below = 0;
  for (float v : h.z)
    if (v < spill) expected += double(spill) - double(v), below++;
  const FillResult f = priority_flood_fill(h);
  EXPECT_NEAR(f.volume_m3, expected * 25.0, 1e-6 * expected * 25.0);
  EXPECT_EQ(f.cells_raised, below);
  EXPECT_DOUBLE_EQ(f.max_depth_m, double(spill) - h.at(15, 15));

  const BreachResult b = breach_depressions(h);
  EXPECT_GT(b.volume_m3, 0.0);
  EXPECT_LT(b.volume_m3, f.volume_m3);  // a channel is much cheaper than the filled lake
  EXPECT_EQ(priority_flood_fill(b.breached).cells_raised, 0u);
  EXPECT_EQ(b.pits_raised, 1u);  // the bottom cell is below all its neighbours
  EXPECT_EQ(b.breached.at(15, 15), h.at(15, 14));
  const BreachResult cut = breach_depressions(h, false);
  EXPECT_EQ(cut.breached.at(15, 15), h.at(15, 15));  // the channel runs at the bottom's level
  EXPECT_EQ(priority_flood_fill(cut.breached).cells_raised, 0u);
  // The channel is one straight line of 15 cells to the middle of the north border (index order
  // breaks the tie between the four equally low border midpoints).
  EXPECT_EQ(cut.cells_lowered, 15u);
  for (int y = 0; y < 15; ++y) EXPECT_EQ(cut.breached.at(15, y), h.at(15, 15)) << y;

  const D8Result d8 = d8_flow(h);
  EXPECT_EQ(d8.outflow_cells, double(n * n));
  for (size_t i = 0; i < h.size(); ++i) ASSERT_GE(steps_to_outlet(d8, i), 0) << i;
  // The bottom's water leaves through the spill point: some outlet collects the whole lake.
  double biggest = 0;
  for (size_t i = 0; i < h.size(); ++i)
    if (d8.dir[i] == kOutlet) biggest = std::max(biggest, d8.cells[i]);
  EXPECT_GE(biggest, double(below) / 4.0);
  EXPECT_NEAR(dinf_flow(h).outflow_cells, double(n * n), 1e-9);
}

TEST(AnalysisFlow, PlaneBetweenNeighboursGivesExactD8AndDinfShares) {
  for (double sy : {0.25, 0.5}) {
    // z drops 1 m per cell to the east and sy m per cell to the south (1 m cells); all exact floats.
    Heightfield h = grid(12, 10, 1.0);
    for (int y = 0; y < h.height; ++y)
      for (int x = 0; x < h.width; ++x) h.at(x, y) = float(1000.0 - x - sy * y);
    const D8Result d8 = d8_flow(h);
    const DinfResult di = dinf_flow(h);
    // D8: east drops 1 / 1, south-east (1 + sy) / sqrt 2: 0.884 (sy 0.25) or 1.061 (sy 0.5).
    const uint8_t expect_d8 = (1.0 + sy) / std::sqrt(2.0) > 1.0 ? 1 : 0;
    const double r = std::atan(sy);  // Tarboton's angle within the east/south-east facet
    for (int y = 1; y < h.height - 1; ++y)
      for (int x = 1; x < h.width - 1; ++x) {
        const size_t i = size_t(y) * h.width + x;
        EXPECT_EQ(d8.dir[i], expect_d8);
        EXPECT_EQ(di.k1[i], 0);  // east
        EXPECT_EQ(di.k2[i], 1);  // south-east
        EXPECT_NEAR(di.share1[i], 1.0 - r / (M_PI / 4), 1e-6);
        EXPECT_NEAR(di.angle_rad[i], 2 * M_PI - r, 1e-6);
      }
    EXPECT_EQ(d8.outflow_cells, double(h.size()));
    EXPECT_NEAR(di.outflow_cells, double(h.size()), 1e-9);
  }
}

TEST(AnalysisFlow, FlatTerraceDrainsWithoutOutletsOrCycles) {
  // A slope falling east with a flat terrace in its middle rows; the terrace must drain.
  Heightfield h = grid(30, 20, 10.0);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) h.at(x, y) = float(100 - x);
  for (int y = 4; y < 16; ++y)
    for (int x = 8; x < 20; ++x) h.at(x, y) = 92.f;
  EXPECT_EQ(priority_flood_fill(h).cells_raised, 0u);  // a flat is not a depression
  const FillResult fe = priority_flood_fill(h, true);
  EXPECT_GT(fe.cells_raised, 0u);
  EXPECT_LT(fe.max_depth_m, 1e-3);  // epsilon steps only
  const D8Result d8 = d8_flow(h);
  for (int y = 4; y < 16; ++y)
    for (int x = 8; x < 20; ++x) {
      const size_t i = size_t(y) * h.width + x;
      EXPECT_LT(d8.dir[i], 8) << "terrace cell " << x << "," << y << " has no direction";
      EXPECT_GT(steps_to_outlet(d8, i), 0);
    }
  EXPECT_EQ(d8.outflow_cells, double(h.size()));
  EXPECT_NEAR(dinf_flow(h).outflow_cells, double(h.size()), 1e-9);
}

TEST(AnalysisFlow, EdgeOutflowEqualsCellCountOnRealDems) {
  for (const char* file : {"crops/presidential_128x96.tif", "crops/frontrange_64.asc"}) {
    Heightfield h = read_heightfield(test::data_path(file));
    // Punch a nodata hole: cells next to it become outlets too.
    for (int y = 20; y < 24; ++y)
      for (int x = 30; x < 35; ++x) h.at(x, y) = NAN;
    const size_t valid = h.size() - h.count_nodata();
    const D8Result d8 = d8_flow(h);
    EXPECT_EQ(d8.valid_cells, valid);
    EXPECT_EQ(d8.outflow_cells, double(valid)) << file;
    for (size_t i = 0; i < h.size(); ++i)
      if (!std::isnan(h.z[i])) ASSERT_GE(steps_to_outlet(d8, i), 0) << file << " cell " << i;
    const DinfResult di = dinf_flow(h);
    EXPECT_NEAR(di.outflow_cells, double(valid), 1e-9 * valid) << file;
    // Breaching removes every depression; the result needs no filling.
    const BreachResult b = breach_depressions(h);
    EXPECT_EQ(priority_flood_fill(b.breached).cells_raised, 0u) << file;
    for (size_t i = 0; i < h.size(); ++i) EXPECT_EQ(std::isnan(b.breached.z[i]), std::isnan(h.z[i]));
    // Filling never lowers, breaching never raises (besides raised single-cell pits).
    const FillResult f = priority_flood_fill(h);
    for (size_t i = 0; i < h.size(); ++i)
      if (!std::isnan(h.z[i])) ASSERT_GE(f.filled.z[i], h.z[i]);
  }
}

TEST(AnalysisStats, GiniHypsometryAndSpectralSlope) {
  EXPECT_DOUBLE_EQ(gini({1, 1, 1, 1}), 0.0);
  EXPECT_DOUBLE_EQ(gini({0, 0, 0, 1}), 0.75);
  EXPECT_NEAR(gini({1, 2, 3, 4}), 0.25, 1e-12);

  // A random field with a k^-3 power spectrum (inverse DFT of random phases) must measure ~ -3.
  const int n = 64;
  Heightfield h = grid(n, n, 10.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  for (int v = -n / 2 + 1; v <= n / 2; ++v)
    for (int u = 0; u <= n / 2; ++u) {
      const double k = std::hypot(u, v);
      if (k < 1 || k > n / 2) continue;
      const double amp = std::pow(k, -1.5), ph = phase(rng);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) h.at(x, y) += float(100 * amp * std::cos(2 * M_PI * (u * x + v * y) / n + ph));
    }
  const double beta = spectral_slope(h);
  EXPECT_NEAR(beta, -3.0, 0.35);

  const nlohmann::json m = terrain_metrics(h);
  const double hi = m["hypsometric_integral"].get<double>();
  EXPECT_GT(hi, 0.0);
  EXPECT_LT(hi, 1.0);
  EXPECT_NEAR(m["drainage"]["outflow_cells"].get<double>(), double(n * n), 1e-9);
  EXPECT_LE(m["slope_deg"]["quantiles"]["p05"].get<double>(), m["slope_deg"]["quantiles"]["p95"].get<double>());

  // A linear ramp has hypsometric integral 1/2 and one constant slope.
  Heightfield ramp = grid(16, 16, 10.0);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) ramp.at(x, y) = float(5.0 * x);
  const nlohmann::json r = terrain_metrics(ramp);
  EXPECT_NEAR(r["hypsometric_integral"].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(r["slope_deg"]["quantiles"]["p50"].get<double>(), std::atan(0.5) * 180 / M_PI, 1e-4);
  EXPECT_NEAR(r["laplacian_per_m"]["mean"].get<double>(), 0.0, 1e-9);
}

TEST(AnalysisErrors, BadInputsAreRejectedClearly) {
  Heightfield empty;
  EXPECT_THROW(priority_flood_fill(empty), Error);
  Heightfield h = grid(4, 4, 1.0);
  h.z[5] = INFINITY;
  try {
    breach_depressions(h);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("infinite"), std::string::npos) << e.what();
  }
  Heightfield allnan = grid(4, 4, 1.0);
  for (float& v : allnan.z) v = NAN;
  EXPECT_THROW(terrain_metrics(allnan), Error);
  const D8Result d8 = d8_flow(allnan);  // nothing to route, but no crash
  EXPECT_EQ(d8.outflow_cells, 0.0);
}

// Tarboton's (1997) known answer: on a cone z = -r the flow diverges radially and the specific
// catchment area (upslope area per unit contour width) at distance r is r / 2. With the cell size
// as the contour width, D-infinity measures a mean relative error of 11.5 % over 20 <= r <= 80
// (about 10 % low: its flow lines lie cell * max(|cos t|, |sin t|) apart; up to 27 % high on the 8
// grid directions, where the apex on a cell centre makes two facets tie); D8, which sends each
// cell's flow one way, is 4x further off (45 %). The bounds guard that ranking (docs/analysis.md).
TEST(AnalysisFlow, DinfSpecificCatchmentOnAConeIsHalfTheRadius) {
  const int n = 201, c = n / 2;
  Heightfield h = grid(n, n, 1.0);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h.at(x, y) = float(1000.0 - std::hypot(double(x - c), double(y - c)));
  const DinfResult di = dinf_flow(h);
  const D8Result d8 = d8_flow(h);
  double err_dinf = 0, err_d8 = 0;
  int count = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double r = std::hypot(double(x - c), double(y - c));
      if (r < 20 || r > 80) continue;
      const size_t i = size_t(y) * n + x;
      err_dinf += std::fabs(di.cells[i] - r / 2) / (r / 2);
      err_d8 += std::fabs(d8.cells[i] - r / 2) / (r / 2);
      ++count;
    }
  err_dinf /= count;
  err_d8 /= count;
  EXPECT_LT(err_dinf, 0.13) << "mean relative error of D-infinity";
  EXPECT_GT(err_d8, 3 * err_dinf) << "D8's error " << err_d8;
}
