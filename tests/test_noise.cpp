// Gradient noise (kernels/noise.cl): analytic derivatives against finite differences of the values.
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include <algorithm>
#include <cmath>

using namespace terracl;

namespace {

GradientField noise_field(const NoiseParams& p, int w, int h, double cell, const std::vector<Primitive>& mask = {}) {
  Device& d = test::device();
  GradientField g(w, h);
  g.georef.cell_x = g.georef.cell_y = cell;
  GradientBuffers b = GradientBuffers::upload(d, g);
  if (!mask.empty()) primitive_weight(d, b, mask, full_box(w, h), false);
  noise_gradient(d, b, p, full_box(w, h), !mask.empty(), false);
  b.download(d, g);
  return g;
}

// Median and maximum of |analytic - finite difference| over the x faces, relative to the largest slope.
std::pair<double, double> derivative_error(const NoiseParams& p) {
  const int n = 96;
  const double cell = 0.5;
  const GradientField g = noise_field(p, n, n, cell);
  // Values on a grid shifted by half a cell so that their difference is centred on the x faces.
  const Heightfield v = noise_values(test::device(), 2 * n, n, cell / 2, cell, p);
  std::vector<double> err;
  double gmax = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 1; x < n - 1; ++x) {
      const double fd = (v.at(2 * x + 2, y) - v.at(2 * x, y)) / cell;  // values at x and x + 1
      const double an = g.gx[size_t(y) * n + x];
      err.push_back(std::abs(fd - an));
      gmax = std::max(gmax, std::abs(an));
    }
  std::sort(err.begin(), err.end());
  return {err[err.size() / 2] / gmax, err[err.size() * 99 / 100] / gmax};
}

}  // namespace

TEST(Noise, PerlinDerivativeMatchesFiniteDifferences) {
  NoiseParams p;
  p.type = NoiseType::Perlin;
  p.amplitude = 5;
  p.wavelength = 16;
  const auto [med, p99] = derivative_error(p);
  EXPECT_LT(med, 2e-3);
  EXPECT_LT(p99, 1e-2);
}

TEST(Noise, FbmAndRidgedDerivativesMatchFiniteDifferences) {
  NoiseParams p;
  p.amplitude = 5;
  p.wavelength = 24;
  p.octaves = 3;
  p.type = NoiseType::Fbm;
  auto [med, p99] = derivative_error(p);
  EXPECT_LT(med, 5e-3);
  EXPECT_LT(p99, 3e-2);
  p.type = NoiseType::Ridged;
  std::tie(med, p99) = derivative_error(p);
  EXPECT_LT(med, 5e-3);  // the ridges are kinks: only the bulk must agree
}

TEST(Noise, MaskedNoiseIsNearlyCurlFree) {
  NoiseParams p;
  p.amplitude = 3;
  p.wavelength = 30;
  Primitive disc;
  disc.shape = PrimitiveShape::Disc;
  disc.points = {{32, 32}};
  disc.disc_radius = 8;
  disc.radius = 20;
  const GradientField g = noise_field(p, 64, 64, 1.0, {disc});
  double curl = 0, mag = 0;
  for (int y = 0; y < 62; ++y)
    for (int x = 0; x < 62; ++x) {
      const size_t o = size_t(y) * 64 + x;
      curl = std::max(curl, double(std::abs((g.gx[o + 64] - g.gx[o]) - (g.gy[o + 1] - g.gy[o]))));
      mag = std::max(mag, double(std::abs(g.gx[o])));
    }
  EXPECT_GT(mag, 0.01);
  EXPECT_LT(curl, 0.05 * mag);
  // Nothing outside the mask's support.
  EXPECT_EQ(g.gx[0], 0.f);
  EXPECT_EQ(g.gy[63 * 64 - 1], 0.f);
}

TEST(Noise, DeterministicPerSeed) {
  NoiseParams p;
  const GradientField a = noise_field(p, 32, 32, 10), b = noise_field(p, 32, 32, 10);
  EXPECT_EQ(a.gx, b.gx);
  p.seed = 2;
  const GradientField c = noise_field(p, 32, 32, 10);
  EXPECT_NE(a.gx, c.gx);
}

TEST(Noise, BadParametersAreErrors) {
  NoiseParams p;
  p.wavelength = 0;
  EXPECT_THROW(noise_field(p, 8, 8, 1), Error);
  p.wavelength = 10;
  p.octaves = 0;
  EXPECT_THROW(noise_field(p, 8, 8, 1), Error);
  EXPECT_THROW(parse_noise_type("simplex"), Error);
}

TEST(Noise, OctavesFinerThanFourCellsAreLeftOut) {
  NoiseParams p;
  p.type = NoiseType::Fbm;
  p.wavelength = 80;  // 8 cells of 10 m: octaves of 8, 4, 2, 1 cells
  p.octaves = 4;
  EXPECT_EQ(band_limited_octaves(p, 10, 10), 2);
  EXPECT_EQ(band_limited_octaves(p, 10, 25), 1);  // the first octave is always kept
  const GradientField all = noise_field(p, 48, 40, 10);
  p.octaves = 2;
  const GradientField two = noise_field(p, 48, 40, 10);
  EXPECT_EQ(all.gx, two.gx);
  EXPECT_EQ(all.gy, two.gy);
  p.octaves = 1;
  const GradientField one = noise_field(p, 48, 40, 10);
  EXPECT_NE(one.gx, two.gx);  // the 4-cell octave is still there
}
