// Erosion in physical units (issue 15): the suspended sediment settles back at the end so the output
// keeps all the material, and the defaults give the same result in metres whatever the cell size
// (the same terrain at SRTM3's ~80 m cells and upsampled 3x).
#include "test_helpers.hpp"

#include <terracl/erosion.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

using namespace terracl;

namespace {

double volume_m3(const Heightfield& h) {
  double v = 0;
  for (float z : h.z) v += z;
  return v * h.georef.cell_x * h.georef.cell_y;
}

}  // namespace

TEST(ErosionSettle, OutputKeepsAllTheMaterial) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const double a = dem.georef.cell_x * dem.georef.cell_y;
  ErosionParams p = ErosionParams::defaults();
  ErosionOutputs with, without;
  const Heightfield settled = erode(test::device(), dem, p, 300, nullptr, &with);
  p.settle = false;
  const Heightfield suspended = erode(test::device(), dem, p, 300, nullptr, &without);
  double moved = 0;
  for (size_t i = 0; i < dem.size(); ++i) moved += std::fabs(double(settled.z[i]) - dem.z[i]) * a;
  const double v0 = volume_m3(dem), drift = volume_m3(settled) - v0, lost = v0 - volume_m3(suspended);
  std::printf("volume moved %.4g m3; output - input: %.3g m3 settled, %.4g m3 without settling (suspended %.4g m3)\n",
              moved, drift, -lost, without.totals.sediment);
  ASSERT_GT(moved, 1e6) << "the run must move material for this test to mean anything";
  // Float32 beds of ~1000 m round at 6e-5 m per cell update: allow 1e-4 of the moved volume.
  EXPECT_LE(std::fabs(drift), 1e-4 * moved);
  // Without settling the output lost the suspended load (the old default): far above the bound.
  EXPECT_NEAR(lost, without.totals.sediment, 1e-3 * lost + 1e-4 * moved);
  EXPECT_GT(lost, 100 * 1e-4 * moved);
  EXPECT_NEAR(with.totals.settled, without.totals.sediment, 1e-3 * without.totals.sediment);
  EXPECT_LE(with.totals.sediment, 1e-6 * with.totals.settled);  // nothing left in suspension
  for (size_t i = 0; i < dem.size(); ++i) ASSERT_EQ(with.sediment.z[i], 0.0f);
  // The delta output includes the settled sediment.
  for (size_t i = 0; i < dem.size(); ++i) ASSERT_NEAR(with.delta.z[i], settled.z[i] - dem.z[i], 1e-4);
}

TEST(ErosionSettle, BrushWeightZeroCellsStayFixed) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  std::vector<float> w(dem.size(), 1.0f);
  for (int y = 0; y < dem.height; ++y)
    for (int x = dem.width / 2; x < dem.width; ++x) w[size_t(y) * dem.width + x] = 0.0f;
  ErosionOutputs out;
  const Heightfield e = erode(test::device(), dem, ErosionParams::defaults(), 200, &w, &out);
  for (int y = 0; y < dem.height; ++y)
    for (int x = dem.width / 2; x < dem.width; ++x) ASSERT_EQ(e.at(x, y), dem.at(x, y)) << x << "," << y;
  EXPECT_GT(out.totals.settled, 0.0);
}
