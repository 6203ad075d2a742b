// SPDX-License-Identifier: Apache-2.0
// The perspective picture (render --mode perspective): camera framing and the host reference ray
// marcher in double precision. kernels/render_view.cl is the same algorithm in float, step for step
// (same march samples, same bisection count), so the two differ only where rounding flips a hit.
#include <algorithm>
#include <array>
#include <cmath>
#include <terracl/error.hpp>
#include <terracl/render.hpp>

#include "render/render_window.hpp"
#include "render/view_internal.hpp"

namespace terracl::render {

namespace {

constexpr double kDeg = M_PI / 180.0;

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Data range of the valid cells (NaN when there is none).
std::pair<double, double> data_range(const Heightfield& h) {
  double lo = INFINITY, hi = -INFINITY;
  for (float v : h.z)
    if (!std::isnan(v)) lo = std::min(lo, double(v)), hi = std::max(hi, double(v));
  return {lo, hi};
}

}  // namespace

void check_view(const View& v) {
  if (!(v.fov_deg > 0 && v.fov_deg < 180))
    fail("render", "fov (--fov) must be in (0, 180) deg, exclusive; got {}", v.fov_deg);
  if (!(v.elevation_deg > 0 && v.elevation_deg < 90))
    fail("render", "view_elevation (--view-elevation) must be in (0, 90) deg, exclusive; got {}", v.elevation_deg);
  if (!std::isfinite(v.azimuth_deg)) fail("render", "view_azimuth (--view-azimuth) must be a finite number of degrees");
  if (v.width < 1 || v.height < 1 || v.width > 16384 || v.height > 16384)
    fail("render", "size (--size) must be WxH with 1..16384 pixels a side; got {}x{}", v.width, v.height);
  if (!(v.zoom > 0) || !std::isfinite(v.zoom)) fail("render", "view_zoom (--view-zoom) must be > 0; got {}", v.zoom);
  if (!(v.haze >= 0) || !std::isfinite(v.haze)) fail("render", "haze (--haze) must be >= 0; got {}", v.haze);
  if (v.has_water_level && !std::isfinite(v.water_level))
    fail("render", "water_level (--water-level) must be a finite elevation in metres; got {}", v.water_level);
  if (!(v.water_clarity > 0) || !std::isfinite(v.water_clarity))
    fail("render", "water_clarity (--water-clarity) must be > 0 metres; got {}", v.water_clarity);
  if (v.has_target && !(std::isfinite(v.target[0]) && std::isfinite(v.target[1])))
    fail("render", "view_target (--view-target) must be two finite cell coordinates COL,ROW");
}

namespace detail {

ViewSetup view_setup(const Heightfield& h, const Options& opt) {
  const View& v = opt.view;
  check_view(v);
  if (h.width < 2 || h.height < 2)
    fail("render", "a perspective picture needs at least 2 x 2 cells, got {} x {}", h.width, h.height);
  if (!(h.georef.cell_x > 0 && h.georef.cell_y > 0))
    fail("render", "cell size must be positive, got {} x {} m", h.georef.cell_x, h.georef.cell_y);
  if (!(opt.z_factor > 0) || !std::isfinite(opt.z_factor))
    fail("render", "z_factor (--z-factor) must be > 0 for a perspective picture; got {}", opt.z_factor);
  if (!(opt.altitude_deg >= 0 && opt.altitude_deg <= 90) || !std::isfinite(opt.azimuth_deg))
    fail("render", "the sun's altitude must be in 0..90 deg and its azimuth finite");
  ViewSetup s{};
  s.cell_x = h.georef.cell_x;
  s.cell_y = h.georef.cell_y;
  s.z_factor = opt.z_factor;
  const auto [lo, hi] = data_range(h);
  const bool any = lo <= hi;
  s.zmin = any ? lo : 0.0;
  s.zmax = any ? hi : 0.0;
  // The march box: a hair above the highest cell and below the lowest, so that a ray entering
  // through the top starts above the surface and one leaving through the bottom ends below it.
  const double pad = 1e-3 * std::max(1.0, (s.zmax - s.zmin) * s.z_factor);
  s.zlo = s.zmin * s.z_factor - pad;
  s.zhi = s.zmax * s.z_factor + pad;

  // Water: an explicit level, else sea level where the look has a coast (hypsometric ramp or
  // natural material) and the terrain reaches below it. Water at or below the lowest cell could
  // only show through holes: none, so that such a terrain's picture is unchanged.
  s.material = v.material;
  const bool coastal_look = v.material == Material::Natural || opt.ramp.name == "hypsometric";
  if (v.water && (v.has_water_level || (coastal_look && any && s.zmin < 0))) {
    s.water_level = v.has_water_level ? v.water_level : 0.0;
    s.water = any && s.water_level > s.zmin;
  }
  s.water_z = s.water_level * s.z_factor;
  s.water_clarity = v.water_clarity;
  if (s.water) s.zhi = std::max(s.zhi, s.water_z + pad);  // a sea above every cell still shows
  s.base = s.water ? s.water_level : s.zmin;
  s.top = std::max(s.zmax, s.base + 1e-6);
  s.snow_line = s.base + std::max(kSnowFraction * (s.top - s.base), kSnowMinRise);
  s.noise_lambda = std::max(6 * std::min(s.cell_x, s.cell_y),
                            std::max((h.width - 1) * s.cell_x, (h.height - 1) * s.cell_y) / 128);

  const double az = v.azimuth_deg * kDeg, el = v.elevation_deg * kDeg;
  // Looking from azimuth az (clockwise from north; y points south) down by el.
  const double back[3] = {std::sin(az) * std::cos(el), -std::cos(az) * std::cos(el), std::sin(el)};
  for (int k = 0; k < 3; ++k) s.fwd[k] = -back[k];
  const double r[3] = {-std::cos(az), -std::sin(az), 0.0};
  const double u[3] = {-std::sin(el) * std::sin(az), std::sin(el) * std::cos(az), std::cos(el)};
  const double tx = std::tan(0.5 * v.fov_deg * kDeg), ty = tx * v.height / v.width;

  // Terrain samples (a lattice of at most ~256 a side plus the last row and column) for the framing.
  std::vector<std::array<double, 3>> pts;
  const int stride = std::max(1, (std::max(h.width, h.height) + 255) / 256);
  for (int y = 0;; y = std::min(y + stride, h.height - 1)) {
    for (int x = 0;; x = std::min(x + stride, h.width - 1)) {
      const float z = h.at(x, y);
      if (!std::isnan(z)) pts.push_back({x * s.cell_x, y * s.cell_y, z * s.z_factor});
      if (x == h.width - 1) break;
    }
    if (y == h.height - 1) break;
  }
  if (pts.empty()) pts.push_back({0.5 * (h.width - 1) * s.cell_x, 0.5 * (h.height - 1) * s.cell_y, 0.0});

  if (v.has_eye) {
    std::copy(v.eye, v.eye + 3, s.eye);
  } else {
    // The closest camera (largest fwd coordinate) whose frustum, narrowed by a 4 % margin, holds
    // every sample: per axis the two frustum planes touching the extreme samples meet on the axis
    // position, and the tighter of the two axes sets the distance.
    const double mx = 0.96 * tx, my = 0.96 * ty;
    double ax = -INFINITY, bx = INFINITY, ay = -INFINITY, by = INFINITY;
    for (const auto& p : pts) {
      const double a = dot3(p.data(), r), b = dot3(p.data(), u), c = dot3(p.data(), s.fwd);
      ax = std::max(ax, a - mx * c), bx = std::min(bx, a + mx * c);
      ay = std::max(ay, b - my * c), by = std::min(by, b + my * c);
    }
    double cf = std::min((bx - ax) / (2 * mx), (by - ay) / (2 * my));
    const double cr = 0.5 * (ax + bx), cu = 0.5 * (ay + by);
    // Zoom: toward the frame's centre, at the depth of the terrain's centre.
    const double centre[3] = {0.5 * (h.width - 1) * s.cell_x, 0.5 * (h.height - 1) * s.cell_y,
                              0.5 * (s.zlo + s.zmax * s.z_factor)};
    const double depth = dot3(centre, s.fwd) - cf;
    if (v.has_target) {
      // The target cell's surface point on the view axis, as far away as the centre was.
      const int tx_i = std::clamp(int(std::lround(v.target[0])), 0, h.width - 1);
      const int ty_i = std::clamp(int(std::lround(v.target[1])), 0, h.height - 1);
      const float tz = h.at(tx_i, ty_i);
      const double t[3] = {v.target[0] * s.cell_x, v.target[1] * s.cell_y,
                           std::isnan(tz) ? 0.5 * (s.zlo + s.zhi) : tz * s.z_factor};
      const double dist = std::max(depth, 1e-6) / v.zoom;
      for (int k = 0; k < 3; ++k) s.eye[k] = t[k] - dist * s.fwd[k];
    } else {
      if (v.zoom != 1 && depth > 0) cf += depth * (1 - 1 / v.zoom);
      for (int k = 0; k < 3; ++k) s.eye[k] = cr * r[k] + cu * u[k] + cf * s.fwd[k];
    }
  }
  for (int k = 0; k < 3; ++k) s.right[k] = tx * r[k], s.up[k] = ty * u[k];

  const double sa = opt.azimuth_deg * kDeg, sl = opt.altitude_deg * kDeg;
  s.sun[0] = std::sin(sa) * std::cos(sl);
  s.sun[1] = -std::cos(sa) * std::cos(sl);
  s.sun[2] = std::sin(sl);
  s.shadows = v.shadows;
  // Haze from the nearest terrain sample on, over twice the terrain's diagonal.
  s.haze = v.haze;
  s.haze_near = INFINITY;
  for (const auto& p : pts)
    s.haze_near = std::min(s.haze_near, std::hypot(p[0] - s.eye[0], p[1] - s.eye[1], p[2] - s.eye[2]));
  s.haze_scale = 2 * std::max(std::hypot((h.width - 1) * s.cell_x, (h.height - 1) * s.cell_y), 1e-6);
  return s;
}

std::vector<float> view_slots(const ViewSetup& s) {
  std::vector<float> p;
  for (const double* v : {s.eye, s.fwd, s.right, s.up, s.sun})
    for (int k = 0; k < 3; ++k) p.push_back(float(v[k]));
  for (double d : {s.cell_x, s.cell_y, s.z_factor, s.zlo, s.zhi, s.ambient, s.diffuse, s.haze, s.haze_near,
                   s.haze_scale, s.shadows ? 1.0 : 0.0, s.material == Material::Natural ? 1.0 : 0.0,
                   s.water ? 1.0 : 0.0, s.water_z, s.water_clarity, s.base, 1 / (s.top - s.base),
                   (s.snow_line - s.base) / (s.top - s.base), s.noise_lambda, 1 / s.z_factor, s.deep[0], s.deep[1],
                   s.deep[2]})
    p.push_back(float(d));
  return p;
}

}  // namespace detail

namespace {

using detail::ViewSetup;

// The bilinear surface over the grid, in displayed metres.
struct Surface {
  const Heightfield& h;
  const ViewSetup& s;

  // Displayed height at world (x, y); -inf over a quad with a nodata corner (a hole).
  double at(double x, double y, double* metres = nullptr) const {
    const double fx = x / s.cell_x, fy = y / s.cell_y;
    const int i = std::clamp(int(std::floor(fx)), 0, h.width - 2), j = std::clamp(int(std::floor(fy)), 0, h.height - 2);
    const double ax = std::clamp(fx - i, 0.0, 1.0), ay = std::clamp(fy - j, 0.0, 1.0);
    const double a = h.at(i, j), b = h.at(i + 1, j), c = h.at(i, j + 1), d = h.at(i + 1, j + 1);
    if (std::isnan(a) || std::isnan(b) || std::isnan(c) || std::isnan(d)) return -INFINITY;
    const double z = (1 - ay) * ((1 - ax) * a + ax * b) + ay * ((1 - ax) * c + ax * d);
    if (metres) *metres = z;
    return z * s.z_factor;
  }

  // Central-difference gradient (metres per metre) at vertex (i, j); a missing neighbour (border
  // or nodata) is replaced by the vertex itself, making that side one-sided.
  void vertex_gradient(int i, int j, double& gx, double& gy) const {
    const double c = h.at(i, j);
    auto val = [&](int x, int y, int& used, int fallback) {
      if (x < 0 || y < 0 || x >= h.width || y >= h.height || std::isnan(h.at(x, y))) {
        used = fallback;
        return c;
      }
      return double(h.at(x, y));
    };
    int il = i - 1, ir = i + 1, jt = j - 1, jb = j + 1;
    const double l = val(i - 1, j, il, i), rr = val(i + 1, j, ir, i);
    const double t = val(i, j - 1, jt, j), b = val(i, j + 1, jb, j);
    gx = ir > il ? (rr - l) / ((ir - il) * s.cell_x) : 0.0;
    gy = jb > jt ? (b - t) / ((jb - jt) * s.cell_y) : 0.0;
  }

  // Unit normal at world (x, y): the vertex gradients interpolated bilinearly (smooth shading).
  void normal(double x, double y, double n[3]) const {
    const double fx = x / s.cell_x, fy = y / s.cell_y;
    const int i = std::clamp(int(std::floor(fx)), 0, h.width - 2), j = std::clamp(int(std::floor(fy)), 0, h.height - 2);
    const double ax = std::clamp(fx - i, 0.0, 1.0), ay = std::clamp(fy - j, 0.0, 1.0);
    double g[4][2];
    vertex_gradient(i, j, g[0][0], g[0][1]);
    vertex_gradient(i + 1, j, g[1][0], g[1][1]);
    vertex_gradient(i, j + 1, g[2][0], g[2][1]);
    vertex_gradient(i + 1, j + 1, g[3][0], g[3][1]);
    double gg[2];
    for (int k = 0; k < 2; ++k)
      gg[k] = (1 - ay) * ((1 - ax) * g[0][k] + ax * g[1][k]) + ay * ((1 - ax) * g[2][k] + ax * g[3][k]);
    n[0] = -gg[0] * s.z_factor, n[1] = -gg[1] * s.z_factor, n[2] = 1;
    const double len = std::sqrt(dot3(n, n));
    for (int k = 0; k < 3; ++k) n[k] /= len;
  }

  // Clips the ray o + t d (t >= 0) to the grid's box; false when it misses.
  bool clip(const double* o, const double* d, double& t0, double& t1) const {
    const double lo[3] = {0, 0, s.zlo}, hi[3] = {(h.width - 1) * s.cell_x, (h.height - 1) * s.cell_y, s.zhi};
    t0 = 0, t1 = INFINITY;
    for (int k = 0; k < 3; ++k) {
      if (std::fabs(d[k]) < 1e-12) {
        if (o[k] < lo[k] || o[k] > hi[k]) return false;
        continue;
      }
      double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a), t1 = std::min(t1, b);
    }
    return t0 < t1;
  }

  // March step along d: half a cell horizontally.
  double step(const double* d) const {
    return 0.5 * std::min(s.cell_x, s.cell_y) / std::max(std::hypot(d[0], d[1]), 1e-12);
  }
};

}  // namespace

Image render_view(const Heightfield& h, const Options& opt) {
  const ViewSetup s = detail::view_setup(h, opt);
  const Surface surf{h, s};
  const View& v = opt.view;
  Image img = detail::blank_view(v);
  const double eps = 1e-4 * std::max(s.zhi - s.zlo, 1.0);
  const double wx = (h.width - 1) * s.cell_x, wy = (h.height - 1) * s.cell_y;
  const double inv_range = 1 / (s.top - s.base), snow_e = (s.snow_line - s.base) * inv_range;
  // 1 when a march toward the sun from o finds no surface above it (or shadows are off).
  auto lit_from = [&](const double* o) {
    double u0, u1;
    if (!s.shadows || !surf.clip(o, s.sun, u0, u1)) return 1.0;
    const double ds = surf.step(s.sun);
    for (long k = 1; k * ds < u1; ++k) {
      const double t = k * ds;
      if (o[2] + t * s.sun[2] < surf.at(o[0] + t * s.sun[0], o[1] + t * s.sun[1])) return 0.0;
    }
    return 1.0;
  };
  // Shaded (unhazed) terrain colour at (x, y); `lit` < 0: march for its own shadow.
  auto terrain = [&](double x, double y, double lit, double rgb[3]) {
    double z = 0;
    const double zs = surf.at(x, y, &z);
    double n[3];
    surf.normal(x, y, n);
    double albedo[3];
    if (s.material == Material::Natural) {
      const double e = (z - s.base) * inv_range;
      // The true slope's cosine: the material follows the ground, not its exaggeration.
      const double q = (n[0] * n[0] + n[1] * n[1]) / (s.z_factor * s.z_factor * n[2] * n[2]);
      detail::natural_albedo(x, y, e, e - snow_e, 1 / std::sqrt(q + 1), s.noise_lambda, s.water, albedo);
    } else {
      uint8_t a[3];
      opt.ramp.color(z, s.zmin, s.zmax, a);
      for (int k = 0; k < 3; ++k) albedo[k] = a[k];
    }
    double light = std::max(0.0, dot3(n, s.sun));
    if (light > 0 && lit < 0) {
      // March toward the sun from just above the hit; any surface above the ray shadows it.
      const double o[3] = {x, y, zs + eps};
      light *= lit_from(o);
    } else if (lit >= 0) {
      light *= lit;
    }
    const double shade = s.ambient + s.diffuse * light;
    for (int k = 0; k < 3; ++k) rgb[k] = albedo[k] * shade;
  };
  for (int py = 0; py < v.height; ++py) {
    for (int px = 0; px < v.width; ++px) {
      const double sx = 2.0 * (px + 0.5) / v.width - 1.0, sy = 1.0 - 2.0 * (py + 0.5) / v.height;
      double d[3];
      for (int k = 0; k < 3; ++k) d[k] = s.fwd[k] + sx * s.right[k] + sy * s.up[k];
      const double len = std::sqrt(dot3(d, d));
      for (int k = 0; k < 3; ++k) d[k] /= len;
      double rgb[3];
      // Sky: pale at and below the horizon, deeper blue toward the zenith.
      const double sk = std::sqrt(std::clamp(d[2], 0.0, 1.0));
      for (int k = 0; k < 3; ++k) rgb[k] = detail::kSkyHorizon[k] + sk * (detail::kSkyZenith[k] - detail::kSkyHorizon[k]);
      double t0 = 0, t1, thit = -1;
      if (surf.clip(s.eye, d, t0, t1)) {
        auto f = [&](double t) { return s.eye[2] + t * d[2] - surf.at(s.eye[0] + t * d[0], s.eye[1] + t * d[1]); };
        const double dt = surf.step(d);
        double tp = t0, fp = f(t0);
        // A ray that enters the box below the surface (through a side) sees no terrain: no skirts.
        for (long k = 1; fp > 0; ++k) {
          double t = t0 + k * dt;
          const bool last = t >= t1;
          if (last) t = t1;
          const double ft = f(t);
          if (ft <= 0) {
            double a = tp, b = t;
            for (int it = 0; it < detail::kBisect; ++it) {
              const double m = 0.5 * (a + b);
              (f(m) > 0 ? a : b) = m;
            }
            thit = b;
            break;
          }
          if (last) break;
          tp = t, fp = ft;
        }
      }
      // The water plane, where the ray meets it over the grid before any terrain.
      double tw = -1;
      if (s.water && d[2] < 0 && s.eye[2] > s.water_z) {
        const double t = (s.water_z - s.eye[2]) / d[2];
        const double x = s.eye[0] + t * d[0], y = s.eye[1] + t * d[1];
        if (x >= 0 && x <= wx && y >= 0 && y <= wy && (thit < 0 || t < thit)) tw = t;
      }
      // A ray entering the box below the water through a side sees no sea floor: no water skirts.
      if (s.water && tw < 0 && thit >= 0 && s.eye[2] + t0 * d[2] < s.water_z) thit = -1;
      double tdist = -1, col[3];
      if (tw >= 0) {
        const double x = s.eye[0] + tw * d[0], y = s.eye[1] + tw * d[1];
        const double o[3] = {x, y, s.water_z + eps};
        const double lit = s.sun[2] > 0 ? lit_from(o) : 0.0;
        // Beer-Lambert along the ray's path through the water (in metres: vertical lengths
        // undo the z factor) toward the deep colour, lit by the sun like a flat surface.
        const double path = (thit >= 0 ? thit - tw : INFINITY) *
                            std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] / (s.z_factor * s.z_factor));
        double bed[3] = {0, 0, 0};
        if (thit >= 0) terrain(s.eye[0] + thit * d[0], s.eye[1] + thit * d[1], lit, bed);
        const double body_shade = s.ambient + s.diffuse * std::max(0.0, s.sun[2]) * lit;
        const double ext[3] = {s.water_clarity, s.water_clarity * detail::kClarityG, s.water_clarity * detail::kClarityB};
        // Fresnel (Schlick) toward the sky seen in the mirror direction, plus the sun's glint.
        const double c = std::clamp(-d[2], 0.0, 1.0), m = 1 - c;
        const double fr = detail::kWaterF0 + (1 - detail::kWaterF0) * m * m * m * m * m;
        const double rs = std::sqrt(c);
        const double refl = std::max(0.0, d[0] * s.sun[0] + d[1] * s.sun[1] - d[2] * s.sun[2]);
        const double glint = lit * detail::kGlintGain * 255 * std::pow(refl, detail::kGlintPower);
        for (int k = 0; k < 3; ++k) {
          const double tr = std::exp(-path / ext[k]);
          const double body = bed[k] * tr + s.deep[k] * body_shade * (1 - tr);
          const double sky = detail::kSkyHorizon[k] + rs * (detail::kSkyZenith[k] - detail::kSkyHorizon[k]);
          col[k] = (1 - fr) * body + fr * sky + glint;
        }
        tdist = tw;
      } else if (thit >= 0) {
        terrain(s.eye[0] + thit * d[0], s.eye[1] + thit * d[1], -1, col);
        tdist = thit;
      }
      if (tdist >= 0) {
        const double hz = s.haze > 0 ? 1 - std::exp(-s.haze * std::max(0.0, tdist - s.haze_near) / s.haze_scale) : 0;
        for (int k = 0; k < 3; ++k) rgb[k] = col[k] * (1 - hz) + detail::kSkyHorizon[k] * hz;
      }
      uint8_t* o = &img.pixels[(size_t(py) * v.width + px) * 3];
      for (int k = 0; k < 3; ++k) o[k] = detail::to_byte(rgb[k]);
    }
    if ((py & 31) == 31) report_progress(opt.progress, "render", double(py + 1) / v.height, "perspective");
  }
  return img;
}

}  // namespace terracl::render
