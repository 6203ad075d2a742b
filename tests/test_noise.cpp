// SPDX-License-Identifier: Apache-2.0
// Gradient noise (kernels/noise.cl): analytic derivatives against finite differences of the values.
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <utility>
#include <vector>

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

namespace {

// In-place radix-2 FFT of a row of length 2^k.
void fft(std::vector<std::complex<double>>& a) {
  const size_t n = a.size();
  for (size_t i = 1, j = 0; i < n; ++i) {
    size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (size_t len = 2; len <= n; len <<= 1) {
    const std::complex<double> w = std::polar(1.0, -2 * M_PI / double(len));
    for (size_t i = 0; i < n; i += len) {
      std::complex<double> wk = 1;
      for (size_t k = 0; k < len / 2; ++k, wk *= w) {
        const auto u = a[i + k], v = a[i + k + len / 2] * wk;
        a[i + k] = u + v, a[i + k + len / 2] = u - v;
      }
    }
  }
}

// Power spectrum |FFT|^2 of the curvature of the n x n values (n a power of two), Hann-windowed,
// added to `power`. The curvature (the isotropic nine-point Laplacian) whitens the steep height
// spectrum: the window's leakage of the strong long wavelengths, which runs along the axes, would
// otherwise swamp the short ones.
void add_power(const Heightfield& h, std::vector<double>& power) {
  const int n = h.width;
  std::vector<std::vector<std::complex<double>>> rows(n, std::vector<std::complex<double>>(n));
  auto z = [&](int x, int y) { return double(h.at(std::clamp(x, 0, n - 1), std::clamp(y, 0, n - 1))); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double lap = (4 * (z(x - 1, y) + z(x + 1, y) + z(x, y - 1) + z(x, y + 1)) + z(x - 1, y - 1) +
                          z(x + 1, y - 1) + z(x - 1, y + 1) + z(x + 1, y + 1) - 20 * z(x, y)) / 6;
      const double wx = std::sin(M_PI * x / n), wy = std::sin(M_PI * y / n);
      rows[y][x] = lap * wx * wx * wy * wy;
    }
  for (auto& r : rows) fft(r);
  std::vector<std::complex<double>> col(n);
  power.resize(size_t(n) * n);
  for (int x = 0; x < n; ++x) {
    for (int y = 0; y < n; ++y) col[y] = rows[y][x];
    fft(col);
    for (int y = 0; y < n; ++y) power[size_t(y) * n + x] += std::norm(col[y]);
  }
}

// Mean power within `wedge` degrees of the 0/90 degree axes over the mean within `wedge` of the
// diagonals, at radii (lo, hi) cycles per n cells. The curvature and hillshade spectra are the
// height spectrum times isotropic weights (|k|^4, |k|^2), nearly constant in a radial band: 1 for an
// isotropic field.
double axis_over_diagonal(const std::vector<double>& power, int n, double lo, double hi, double wedge) {
  double ax = 0, dg = 0;
  int nax = 0, ndg = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int kx = x <= n / 2 ? x : x - n, ky = y <= n / 2 ? y : y - n;
      const double r = std::hypot(kx, ky);
      if (r <= lo || r >= hi) continue;
      const double th = std::fmod(std::atan2(double(ky), double(kx)) * 180 / M_PI + 360.0, 90.0);
      const double p = power[size_t(y) * n + x];
      if (th < wedge || th > 90 - wedge) ax += p, ++nax;
      else if (std::abs(th - 45) < wedge) dg += p, ++ndg;
    }
  return (ax / nax) / (dg / ndg);
}

}  // namespace

// Ridged noise once drew east-west and north-south lattice lines in hillshade: every octave sampled
// one axis-aligned lattice, so Perlin noise's leak along its lattice axes stacked up on the map's rows
// and columns. Measured on the curvature spectrum of four seeds at 512^2 cells (first octave 32 cells,
// wavelengths 4-32 cells), the old kernel's fbm had 1.30-1.61 times more energy within 4 degrees of
// the axes than of the diagonals (ridged 0.99-1.06 by this measure: its lines are thinner than the
// wedge's statistics resolve); with rotated octaves both stay within 0.84-1.12.
TEST(Noise, RidgedAndFbmNoiseHaveNoLatticeAxes) {
  const int n = 512;
  for (NoiseType type : {NoiseType::Ridged, NoiseType::Fbm}) {
    NoiseParams p;
    p.type = type;
    p.amplitude = 1;
    p.wavelength = 32;
    p.octaves = 4;
    std::vector<double> power;
    for (uint32_t seed : {1u, 2u, 3u, 4u}) {
      p.seed = seed;
      add_power(noise_values(test::device(), n, n, 1.0, 1.0, p), power);
    }
    for (auto [lo, hi] : {std::pair{16.0, 32.0}, {32.0, 64.0}, {64.0, 128.0}}) {
      const double a = axis_over_diagonal(power, n, lo, hi, 4.0);
      EXPECT_LT(std::abs(std::log(a)), std::log(1.25))
          << "noise type " << int(type) << ", wavelengths " << n / hi << "-" << n / lo << " cells: axis/diagonal " << a;
    }
  }
}
