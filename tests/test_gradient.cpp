// SPDX-License-Identifier: Apache-2.0
// Gradient extraction, divergence and the central-difference format against CPU loops.
#include "test_helpers.hpp"
#include "recon_reference.hpp"

#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>

#include <random>

using namespace terracl;

namespace {

Heightfield random_field(int w, int h, double cx, double cy, unsigned seed) {
  Heightfield t(w, h);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(500.f, 1500.f);
  for (float& v : t.z) v = u(rng);
  t.georef.cell_x = cx;
  t.georef.cell_y = cy;
  return t;
}

}  // namespace

TEST(Gradient, StaggeredMatchesForwardDifferencesBitExact) {
  Heightfield h = random_field(37, 22, 30.0, 20.0, 3);
  GradientField g = extract_gradient(test::device(), h);
  ASSERT_EQ(g.width, 37);
  const float ix = float(1.0 / 30.0), iy = float(1.0 / 20.0);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const size_t i = size_t(y) * h.width + x;
      const float ex = x + 1 < h.width ? (h.at(x + 1, y) - h.at(x, y)) * ix : 0.f;
      const float ey = y + 1 < h.height ? (h.at(x, y + 1) - h.at(x, y)) * iy : 0.f;
      ASSERT_EQ(g.gx[i], ex) << x << "," << y;
      ASSERT_EQ(g.gy[i], ey) << x << "," << y;
    }
  EXPECT_EQ(gradient_format(g), GradientFormat::Staggered);
  double mean = 0;
  for (float v : h.z) mean += v;
  EXPECT_NEAR(g.mean_elevation, mean / h.size(), 1e-9);
}

TEST(Gradient, DivergenceOfExtractIsTheNeumannLaplacian) {
  Heightfield h = test::smooth_terrain(41, 29, 25.0, 300.0, 5);
  h.georef.cell_y = 15.0;  // anisotropic cells
  Heightfield f = divergence(test::device(), extract_gradient(test::device(), h));
  std::vector<double> hd(h.z.begin(), h.z.end());
  const std::vector<double> ref = test::laplacian(hd, h.width, h.height, 25.0, 15.0);
  double scale = 0;
  for (double v : ref) scale = std::max(scale, std::fabs(v));
  for (size_t i = 0; i < ref.size(); ++i) ASSERT_NEAR(f.z[i], ref[i], 1e-5 * scale + 1e-6) << i;
}

TEST(Gradient, CentralExportMatchesThePaperFormula) {
  Heightfield h = random_field(9, 7, 2.0, 4.0, 8);
  GradientField c = extract_gradient(test::device(), h, GradientFormat::Central);
  EXPECT_EQ(gradient_format(c), GradientFormat::Central);
  // interior: (h[x+1]-h[x-1]) / 2d; border: one-sided
  EXPECT_NEAR(c.gx[3 * 9 + 4], (h.at(5, 3) - h.at(3, 3)) / 4.0, 1e-3);
  EXPECT_NEAR(c.gy[3 * 9 + 4], (h.at(4, 4) - h.at(4, 2)) / 8.0, 1e-3);
  EXPECT_NEAR(c.gx[3 * 9 + 0], (h.at(1, 3) - h.at(0, 3)) / 2.0, 1e-3);
  EXPECT_NEAR(c.gy[6 * 9 + 2], (h.at(2, 6) - h.at(2, 5)) / 4.0, 1e-3);
}

TEST(Gradient, CentralImportApproximatesStaggered) {
  Heightfield h = test::smooth_terrain(64, 48, 10.0, 200.0, 2);
  GradientField s = extract_gradient(test::device(), h);
  GradientField c = to_staggered(test::device(), extract_gradient(test::device(), h, GradientFormat::Central));
  EXPECT_EQ(gradient_format(c), GradientFormat::Staggered);
  double err = 0, mag = 0;
  for (int y = 1; y + 2 < h.height; ++y)
    for (int x = 1; x + 2 < h.width; ++x) {
      const size_t i = size_t(y) * h.width + x;
      err = std::max(err, double(std::fabs(c.gx[i] - s.gx[i])));
      mag = std::max(mag, double(std::fabs(s.gx[i])));
    }
  EXPECT_LT(err, 0.02 * mag);  // second-order accurate on a smooth field, not exact
}

TEST(Gradient, NaNInputIsRejected) {
  Heightfield h = random_field(8, 8, 1, 1, 1);
  h.at(3, 4) = NAN;
  EXPECT_THROW(extract_gradient(test::device(), h), Error);
}

TEST(Gradient, CliExtractWritesATwoChannelExr) {
  test::TempDir dir;
  auto r = test::run_cli("extract " + test::data_path("crops/presidential_128x96.tif") + " -o " + dir.path("g.exr") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  GradientField g = read_gradient(dir.path("g.exr"));
  EXPECT_EQ(g.width, 128);
  EXPECT_EQ(g.height, 96);
  EXPECT_TRUE(std::isfinite(g.mean_elevation));
  EXPECT_GT(g.georef.cell_x, 1.0);  // metric cell size carried
  auto c = test::run_cli("extract " + test::data_path("crops/presidential_128x96.tif") + " -o " + dir.path("c.exr") +
                         " --central -q");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_EQ(gradient_format(read_gradient(dir.path("c.exr"))), GradientFormat::Central);
}
