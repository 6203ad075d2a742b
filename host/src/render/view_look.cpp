// SPDX-License-Identifier: Apache-2.0
// The perspective view's looks beyond the ramp: the natural material (albedo from slope and
// elevation broken by world-space value noise) and the water surface (Beer-Lambert body, Fresnel
// sky reflection, sun glint). kernels/render_material.clh and render_view.cl are the same formulas
// in float; both backends take their constants from here through the slots or the same literals.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "render/view_internal.hpp"

namespace terracl::render::detail {

namespace {

uint32_t mat_hash(int ix, int iy, uint32_t seed) {
  uint32_t h = (uint32_t(ix) * 0x8da6b343u) ^ (uint32_t(iy) * 0xd8163841u) ^ (seed * 0xcb1ab31fu);
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

double lattice(int ix, int iy, uint32_t seed) { return double(mat_hash(ix, iy, seed) >> 8) * (2.0 / 16777216.0) - 1.0; }

double value_noise(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int ix = int(fx), iy = int(fy);
  const double ax = x - fx, ay = y - fy;
  const double ux = ax * ax * ax * (ax * (ax * 6 - 15) + 10), uy = ay * ay * ay * (ay * (ay * 6 - 15) + 10);
  const double a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const double c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  return (1 - uy) * ((1 - ux) * a + ux * b) + uy * ((1 - ux) * c + ux * d);
}

double smooth(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

void mix(double* c, double r, double g, double b, double t) {
  c[0] += t * (r - c[0]);
  c[1] += t * (g - c[1]);
  c[2] += t * (b - c[2]);
}

}  // namespace

double material_noise(double x, double y, double lam, uint32_t seed) {
  // Octave k: rotation 0.5 + 2.39996 k rad (golden-angle steps), wavelength 2.5^k lam, offset k (17.13, -9.71).
  static const double c[3] = {0.87758256, -0.97094937, 0.55431313}, s[3] = {0.47942554, 0.23928503, -0.83230821};
  static const double wgt[3] = {0.2, 0.3, 0.5};
  double sum = 0, wl = lam;
  for (int k = 0; k < 3; ++k) {
    const double u = (c[k] * x - s[k] * y) / wl + 17.13 * k, v = (s[k] * x + c[k] * y) / wl - 9.71 * k;
    sum += wgt[k] * value_noise(u, v, seed + uint32_t(k));
    wl *= 2.5;
  }
  return sum;
}

void natural_albedo(double x, double y, double e, double es, double nz, double lam, bool shore, double c[3]) {
  const double j = material_noise(x, y, lam, 7u), j2 = material_noise(x, y, 2 * lam, 13u);
  const double slope = std::acos(std::clamp(nz, 0.0, 1.0)) * 57.29577951 + 5 * j;
  c[0] = 92, c[1] = 128, c[2] = 58;
  mix(c, 56, 86, 42, 0.7 * smooth(-0.25, 0.35, j2));
  mix(c, 122, 126, 82, smooth(-0.35, -0.05, es + 0.12 * j));
  if (shore) mix(c, 196, 180, 136, 1 - smooth(0.002, 0.012, e + 0.006 * j));
  mix(c, 132, 120, 102, smooth(22, 30, slope));
  const double r = smooth(-0.3, 0.3, j2);
  mix(c, 96 + r * 46, 90 + r * 44, 84 + r * 40, smooth(33, 41, slope));
  mix(c, 238, 240, 244, smooth(0, 0.05, es + 0.04 * j) * (1 - smooth(40, 55, slope)));
  const double t = 1 + 0.16 * material_noise(x, y, 0.4 * lam, 11u);
  for (int k = 0; k < 3; ++k) c[k] *= t;
}

}  // namespace terracl::render::detail
