// SPDX-License-Identifier: Apache-2.0
#include "authoring/landform.hpp"

#include <terracl/amplify.hpp>  // parallel_for

#include <algorithm>
#include <array>
#include <cmath>

namespace terracl::edit {

Box box_around(const Grid& g, const std::vector<Vec2>& pts, double margin) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : pts) x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  Box b;
  if (pts.empty()) return b;
  const int cx0 = std::max(0, cell_index(std::floor((x0 - margin) / g.cell_x)));
  const int cy0 = std::max(0, cell_index(std::floor((y0 - margin) / g.cell_y)));
  const int cx1 = std::min(g.width - 1, cell_index(std::ceil((x1 + margin) / g.cell_x)));
  const int cy1 = std::min(g.height - 1, cell_index(std::ceil((y1 + margin) / g.cell_y)));
  b.x0 = cx0, b.y0 = cy0, b.w = cx1 - cx0 + 1, b.h = cy1 - cy0 + 1;
  if (b.w <= 0 || b.h <= 0) b.w = b.h = 0;
  return b;
}

const ShapeRaster& add_change(EditState& s, ShapeRaster& change, int sign) {
  if (change.box.empty()) return change;
  for (float& v : change.v) {
    if (!std::isfinite(v)) v = 0;  // never a NaN into the field
    if (sign > 0) v = std::max(v, 0.0f);
    if (sign < 0) v = std::min(v, 0.0f);
  }
  GradientBuffers& b = s.buffers();
  const Box& c = change.box;
  // Faces whose value depends on the change: those of the box plus the row and column before it.
  const int rx0 = std::max(0, c.x0 - 1), ry0 = std::max(0, c.y0 - 1);
  const int rw = c.x0 + c.w - rx0, rh = c.y0 + c.h - ry0;
  std::vector<float> gx(size_t(rw) * rh), gy(size_t(rw) * rh);
  const std::array<size_t, 3> origin{size_t(rx0) * sizeof(float), size_t(ry0), 0}, host{0, 0, 0};
  const std::array<size_t, 3> extent{size_t(rw) * sizeof(float), size_t(rh), 1};
  const size_t pitch = size_t(b.width) * sizeof(float), hpitch = size_t(rw) * sizeof(float);
  auto& q = s.device().queue();
  q.enqueueReadBufferRect(b.gx, CL_FALSE, origin, host, extent, pitch, 0, hpitch, 0, gx.data());
  q.enqueueReadBufferRect(b.gy, CL_TRUE, origin, host, extent, pitch, 0, hpitch, 0, gy.data());
  auto d = [&](int x, int y) -> double { return change.contains(x, y) ? double(change.at(x, y)) : 0.0; };
  for (int y = ry0; y < ry0 + rh; ++y)
    for (int x = rx0; x < rx0 + rw; ++x) {
      const size_t i = size_t(y - ry0) * rw + (x - rx0);
      if (x + 1 < b.width) gx[i] = float(double(gx[i]) + (d(x + 1, y) - d(x, y)) / b.cell_x);
      if (y + 1 < b.height) gy[i] = float(double(gy[i]) + (d(x, y + 1) - d(x, y)) / b.cell_y);
    }
  q.enqueueWriteBufferRect(b.gx, CL_FALSE, origin, host, extent, pitch, 0, hpitch, 0, gx.data());
  q.enqueueWriteBufferRect(b.gy, CL_TRUE, origin, host, extent, pitch, 0, hpitch, 0, gy.data());
  const int W = s.grid().width;
  for (int y = c.y0; y < c.y0 + c.h; ++y)
    for (int x = c.x0; x < c.x0 + c.w; ++x) {
      const size_t i = size_t(y) * W + x;
      if (!std::isnan(s.hard()[i])) s.set_hard(i, s.hard()[i] + change.at(x, y));
    }
  s.changed();
  return change;
}

const Heightfield& terrain_estimate(EditState& s) {
  const Heightfield* last = s.last_solution();
  return last ? *last : s.height();
}

double terrain_at(EditState& s, double x, double y) { return sample_at(terrain_estimate(s), s.grid(), x, y); }

double sample_at(const Heightfield& h, const Grid& g, double x, double y) {
  const double fx = std::clamp(x / g.cell_x, 0.0, h.width - 1.0), fy = std::clamp(y / g.cell_y, 0.0, h.height - 1.0);
  const int x0 = std::min(int(fx), std::max(0, h.width - 2)), y0 = std::min(int(fy), std::max(0, h.height - 2));
  const int x1 = std::min(x0 + 1, h.width - 1), y1 = std::min(y0 + 1, h.height - 1);
  const double tx = fx - x0, ty = fy - y0;
  return (1 - ty) * ((1 - tx) * h.at(x0, y0) + tx * h.at(x1, y0)) + ty * ((1 - tx) * h.at(x0, y1) + tx * h.at(x1, y1));
}

GroundAround ground_around(EditState& s, const std::vector<Vec2>& pts, double radius) {
  const Heightfield& h = terrain_estimate(s);
  const Grid& g = s.grid();
  const Box b = box_around(g, pts, radius);
  GroundAround out;
  if (b.empty()) return out;
  // A sparse sample is enough for quantiles; at most ~64k cells are read.
  const int step = std::max(1, int(std::sqrt(double(b.w) * b.h / 65536.0)));
  std::vector<float> v, t;
  for (int y = b.y0; y < b.y0 + b.h; y += step)
    for (int x = b.x0; x < b.x0 + b.w; x += step) {
      const float z = h.at(x, y);
      if (!std::isfinite(z)) continue;
      v.push_back(z);
      const int xl = std::max(0, x - 1), xr = std::min(g.width - 1, x + 1);
      const int yu = std::max(0, y - 1), yd = std::min(g.height - 1, y + 1);
      if (xr == xl || yd == yu) continue;
      const double gx = (double(h.at(xr, y)) - h.at(xl, y)) / ((xr - xl) * g.cell_x);
      const double gy = (double(h.at(x, yd)) - h.at(x, yu)) / ((yd - yu) * g.cell_y);
      if (std::isfinite(gx) && std::isfinite(gy)) t.push_back(float(std::hypot(gx, gy)));
    }
  const auto quantile = [](std::vector<float>& a, double q) {
    const size_t i = std::min(a.size() - 1, size_t(q * double(a.size() - 1) + 0.5));
    std::nth_element(a.begin(), a.begin() + i, a.end());
    return double(a[i]);
  };
  if (v.size() >= 2) out.relief = quantile(v, 0.95) - quantile(v, 0.05);
  if (t.size() >= 2) out.steep_tan = quantile(t, 0.90);
  return out;
}

uint64_t Rng::next() {
  // splitmix64: well mixed, one multiply-xorshift chain per draw.
  uint64_t z = (m_s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

namespace {
inline uint32_t hash3(int32_t x, int32_t y, uint32_t seed) {
  uint32_t h = uint32_t(x) * 0x8DA6B343u ^ uint32_t(y) * 0xD8163841u ^ seed * 0xCB1AB31Fu;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}
inline double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
inline double corner(int32_t ix, int32_t iy, double dx, double dy, uint32_t seed) {
  // One of 16 unit directions, so the lattice has no axis-aligned bias.
  static const std::array<std::array<double, 2>, 16> dirs = [] {
    std::array<std::array<double, 2>, 16> d{};
    for (int k = 0; k < 16; ++k) d[k] = {std::cos(k * M_PI / 8 + 0.1963), std::sin(k * M_PI / 8 + 0.1963)};
    return d;
  }();
  const auto& g = dirs[hash3(ix, iy, seed) & 15u];
  return g[0] * dx + g[1] * dy;
}
}  // namespace

double gradient_noise(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = int32_t(fx), iy = int32_t(fy);
  const double dx = x - fx, dy = y - fy, u = fade(dx), v = fade(dy);
  const double a = corner(ix, iy, dx, dy, seed), b = corner(ix + 1, iy, dx - 1, dy, seed);
  const double c = corner(ix, iy + 1, dx, dy - 1, seed), d = corner(ix + 1, iy + 1, dx - 1, dy - 1, seed);
  return 1.4 * ((a + u * (b - a)) + v * ((c + u * (d - c)) - (a + u * (b - a))));
}

namespace {
// cos and sin of 0.5 k, the rotation of octave k (the same doubles as computing them per sample).
struct OctaveRotations {
  std::array<double, 16> c{}, s{};
  OctaveRotations() {
    for (int k = 0; k < 16; ++k) c[k] = std::cos(0.5 * k), s[k] = std::sin(0.5 * k);
  }
};
const OctaveRotations kRot;
}  // namespace

double fbm(double x, double y, int octaves, double gain, uint32_t seed) {
  double sum = 0, amp = 1, norm = 0, f = 1;
  for (int k = 0; k < octaves; ++k) {
    // Each octave is rotated by an irrational angle so that lattice directions do not line up.
    const double c = k < 16 ? kRot.c[k] : std::cos(0.5 * k), s = k < 16 ? kRot.s[k] : std::sin(0.5 * k);
    sum += amp * gradient_noise(f * (c * x - s * y) + 17.3 * k, f * (s * x + c * y) - 9.1 * k, seed + 101u * uint32_t(k));
    norm += amp;
    amp *= gain;
    f *= 2;
  }
  return norm > 0 ? sum / norm : 0.0;
}

double ridged(double x, double y, int octaves, double gain, uint32_t seed) {
  double sum = 0, amp = 1, norm = 0, f = 1, weight = 1;
  for (int k = 0; k < octaves; ++k) {
    const double c = k < 16 ? kRot.c[k] : std::cos(0.5 * k), s = k < 16 ? kRot.s[k] : std::sin(0.5 * k);
    const double n = gradient_noise(f * (c * x - s * y) + 17.3 * k, f * (s * x + c * y) - 9.1 * k, seed + 101u * uint32_t(k));
    double r = 1 - std::abs(n);
    r *= r;
    // Finer octaves are stronger on crests than in troughs (Musgrave's weighting), as erosion leaves
    // sharp ridges and smooth valley floors.
    sum += amp * r * weight;
    norm += amp;
    weight = std::clamp(0.5 + r, 0.0, 1.0);
    amp *= gain;
    f *= 2;
  }
  return norm > 0 ? 2.0 * sum / norm - 0.9 : 0.0;
}

int octaves_down_to_cells(double wavelength, double cell) {
  int n = 1;
  while (n < 12 && wavelength / std::pow(2.0, n) >= 2.5 * cell) ++n;
  return n;
}

std::vector<Vec2> resample(const std::vector<Vec2>& pts, double step) {
  if (pts.size() < 2 || !(step > 0)) return pts;
  std::vector<Vec2> out{pts.front()};
  for (size_t i = 1; i < pts.size(); ++i) {
    const Vec2 a = pts[i - 1], b = pts[i];
    const int n = std::clamp(int(std::ceil(std::hypot(b.x - a.x, b.y - a.y) / step)), 1, 100000);
    for (int k = 1; k <= n; ++k) out.push_back({a.x + (b.x - a.x) * k / n, a.y + (b.y - a.y) * k / n});
  }
  return out;
}

std::vector<double> arc_lengths(const std::vector<Vec2>& pts) {
  std::vector<double> a(pts.size(), 0.0);
  for (size_t i = 1; i < pts.size(); ++i) a[i] = a[i - 1] + std::hypot(pts[i].x - pts[i - 1].x, pts[i].y - pts[i - 1].y);
  return a;
}

std::vector<Vec2> wander(const std::vector<Vec2>& pts, double amp, double wavelength, int octaves, uint32_t seed) {
  if (pts.size() < 2 || amp == 0 || !(wavelength > 0)) return pts;
  const auto arc = arc_lengths(pts);
  const double L = arc.back();
  std::vector<Vec2> out(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    const Vec2 a = pts[i > 0 ? i - 1 : i], b = pts[i + 1 < pts.size() ? i + 1 : i];
    const double l = std::max(1e-9, std::hypot(b.x - a.x, b.y - a.y));
    const double nx = -(b.y - a.y) / l, ny = (b.x - a.x) / l;
    // The offset fades in with a zero slope, so the line leaves its ends in the drawn direction
    // (what lies beyond an end, e.g. a cliff's plateau edge, continues that direction).
    const double t = std::min(1.0, std::min(arc[i], L - arc[i]) / std::max(1e-9, 0.5 * wavelength));
    const double end = t * t * (3 - 2 * t);
    const double off = amp * end * fbm(arc[i] / wavelength, 0.37, octaves, 0.5, seed);
    out[i] = {pts[i].x + nx * off, pts[i].y + ny * off};
  }
  return out;
}

void max_ridge(ShapeRaster& out, const Grid& g, const RidgeLine& line, double sharpness) {
  const auto& P = line.pts;
  for (size_t i = 0; i + 1 < P.size(); ++i) {
    const Vec2 a = P[i], b = P[i + 1];
    const double wmax = std::max(line.w[i], line.w[i + 1]);
    if (!(wmax > 0) || (line.h[i] <= 0 && line.h[i + 1] <= 0)) continue;
    const Box bb = box_around(g, {a, b}, wmax);
    const int x0 = std::max(bb.x0, out.box.x0), x1 = std::min(bb.x0 + bb.w, out.box.x0 + out.box.w);
    const int y0 = std::max(bb.y0, out.box.y0), y1 = std::min(bb.y0 + bb.h, out.box.y0 + out.box.h);
    const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const double px = x * g.cell_x, py = y * g.cell_y;
        const double t = l2 > 0 ? std::clamp(((px - a.x) * ux + (py - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
        const double w = line.w[i] + t * (line.w[i + 1] - line.w[i]);
        const double u = std::hypot(px - a.x - t * ux, py - a.y - t * uy) / w;
        if (u >= 1) continue;
        const double h = line.h[i] + t * (line.h[i + 1] - line.h[i]);
        // Rounded: a cosine dome; sharp: a concave flank (1 - u)^2 (1 + u) with a cusp at the crest.
        const double round = 0.5 * (1 + std::cos(M_PI * u));
        const double sharp = (1 - u) * (1 - u) * (1 + 0.6 * u) / 1.0;
        const double f = h * ((1 - sharpness) * round + sharpness * sharp);
        float& o = out.at(x, y);
        o = std::max(o, float(f));
      }
  }
}

// Amplitude ratio between octaves of the detail: above 0.5 (a Brownian surface's), as real DEMs
// keep more relief at the finest scales than a smooth fractal (scripts/landform-relief.py).
constexpr double kDetailGain = 0.62;

void add_relief_detail(ShapeRaster& shape, const Grid& g, double amp, double wavelength, uint32_t seed, double cap) {
  if (shape.box.empty() || amp == 0 || !(wavelength > 0)) return;
  const double cell = std::max(g.cell_x, g.cell_y);
  const int oct = octaves_down_to_cells(wavelength, cell);
  const Box& b = shape.box;
  parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
    for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
      for (int x = b.x0; x < b.x0 + b.w; ++x) {
        float& v = shape.at(x, y);
        if (v == 0) continue;
        const double px = x * g.cell_x / wavelength, py = y * g.cell_y / wavelength;
        const double r = amp * ridged(px, py, oct, kDetailGain, seed);
        v = float(v <= cap ? v * (1.0 + r) : v + cap * r);
      }
  });
}

}  // namespace terracl::edit
