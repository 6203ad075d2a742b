// SPDX-License-Identifier: Apache-2.0
#pragma once
// Host mirror of kernels/render_window.clh in double precision: gdaldem's 3x3 window with its
// edge and nodata rules, its shadings and Horn's slope. The host reference of render.cl and
// render_terrain.cl, and the reference the kernels are tested against.
#include <algorithm>
#include <cmath>
#include <terracl/heightfield.hpp>
#include <terracl/render.hpp>

namespace terracl::render::detail {

inline double ip(double a, double b) { return (std::isnan(a) || std::isnan(b)) ? NAN : 2.0 * a - b; }

/// gdaldem's window at (x, y) (layout 0 1 2 / 3 4 5 / 6 7 8); false where gdaldem writes nodata.
/// See render_window.clh for the rules.
inline bool window(const Heightfield& h, int x, int y, bool edges, double v[9]) {
  const int w = h.width, ht = h.height;
  const double c = h.at(x, y);
  if (std::isnan(c)) return false;
  const bool border = x == 0 || y == 0 || x == w - 1 || y == ht - 1;
  if (border && (!edges || w < 2 || ht < 2)) return false;
  if (!border) {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) v[3 * j + i] = h.at(x + i - 1, y + j - 1);
  } else if (y == 0 || y == ht - 1) {
    const int xs[3] = {x == 0 ? x : x - 1, x, x == w - 1 ? x : x + 1};
    const int yb = y == 0 ? 1 : ht - 2;
    for (int i = 0; i < 3; ++i) {
      const double a = h.at(xs[i], y), b = h.at(xs[i], yb);
      if (y == 0)
        v[i] = ip(a, b), v[3 + i] = a, v[6 + i] = b;
      else
        v[i] = b, v[3 + i] = a, v[6 + i] = ip(a, b);
    }
  } else {
    const int xb = x == 0 ? 1 : w - 2;
    for (int j = 0; j < 3; ++j) {
      const double a = h.at(x, y + j - 1), b = h.at(xb, y + j - 1);
      if (x == 0)
        v[3 * j] = ip(a, b), v[3 * j + 1] = a, v[3 * j + 2] = b;
      else
        v[3 * j] = b, v[3 * j + 1] = a, v[3 * j + 2] = ip(a, b);
    }
  }
  for (int k = 0; k < 9; ++k)
    if (std::isnan(v[k])) {
      if (!edges) return false;
      v[k] = c;
    }
  return true;
}

inline double horn_x(const double* v) { return (v[0] + v[3] + v[3] + v[6]) - (v[2] + v[5] + v[5] + v[8]); }
inline double horn_y(const double* v) { return (v[6] + v[7] + v[7] + v[8]) - (v[0] + v[1] + v[1] + v[2]); }
// gdaldem -alg ZevenbergenThorne: the four direct neighbours (same signs as Horn's sums).
inline double zt_x(const double* v) { return v[3] - v[5]; }
inline double zt_y(const double* v) { return v[7] - v[1]; }

/// GRASS r.slope.aspect's profile (pcurvature) or tangential (tcurvature) curvature [1/m]: Horn's
/// gradient and the second derivatives of a quadratic fitted to the window, with GRASS's signs
/// (its dx, dy, dxx, ... are minus the derivatives along east and north, so convex profiles are
/// negative), 0 where the gradient is at most 0.001. `kz`: z_factor / scale (elevations times kz).
inline double curvature(const double* v, double cx, double cy, double kz, bool profile) {
  const double gx = horn_x(v) * kz / (8.0 * cx), gy = horn_y(v) * kz / (8.0 * cy);
  const double s4 = v[0] + v[2] + v[6] + v[8] - 8.0 * v[4];
  const double s5 = 4.0 * (v[3] + v[5]) - 2.0 * (v[1] + v[7]);
  const double s6 = 4.0 * (v[1] + v[7]) - 2.0 * (v[3] + v[5]);
  const double s3 = v[6] - v[8] + v[2] - v[0];
  const double dxx = -(s4 + s5) * kz / (6.0 * cx * cx), dyy = -(s4 + s6) * kz / (6.0 * cy * cy);
  const double dxy = -s3 * kz / (4.0 * cx * cy);
  const double g2 = gx * gx + gy * gy;
  if (std::sqrt(g2) <= 0.001) return 0.0;
  const double q = g2 + 1.0, cross = 2.0 * dxy * gx * gy;
  return profile ? (dxx * gx * gx + cross + dyy * gy * gy) / (g2 * q * std::sqrt(q))
                 : (dxx * gy * gy - cross + dyy * gx * gx) / (g2 * std::sqrt(q));
}

/// The constants of one render, derived once (names as in render_window.clh's P_* slots).
struct ShadeParams {
  double inv_ew, inv_ns, zs, sin_alt, cos_az_alt_z, sin_az_alt_z, az, slope_zx, slope_zy, slope_max, flat, cos_alt_z;
  bool zt;  ///< Zevenbergen-Thorne gradient (P_ALG)
  ShadeParams(const Heightfield& h, const Options& o) {
    const double d2r = M_PI / 180.0;
    zt = o.gradient_alg == GradientAlg::ZevenbergenThorne;
    // gdaldem: z / (8 scale) for Horn's sums (weights 1+2+1, two cells apart), z / (2 scale) for
    // Zevenbergen-Thorne's plain differences two cells apart.
    const double zdiv = (zt ? 2.0 : 8.0) * o.scale;
    inv_ew = 1.0 / h.georef.cell_x;
    inv_ns = -1.0 / h.georef.cell_y;
    zs = o.z_factor / zdiv;
    sin_alt = std::sin(o.altitude_deg * d2r);
    cos_alt_z = std::cos(o.altitude_deg * d2r) * zs;
    az = o.azimuth_deg * d2r;
    cos_az_alt_z = std::cos(az) * cos_alt_z;
    sin_az_alt_z = std::sin(az) * cos_alt_z;
    slope_zx = o.z_factor / (zdiv * h.georef.cell_x);
    slope_zy = o.z_factor / (zdiv * h.georef.cell_y);
    slope_max = o.slope_max_deg;
    flat = 1.0 + 254.0 * sin_alt;
  }
  /// The slots of render_window.clh (P_INV_EW ... P_COS_ALT_Z), as floats for the kernels.
  std::vector<float> slots() const {
    return {float(inv_ew), float(inv_ns),   float(zs),       float(sin_alt),   float(cos_az_alt_z), float(sin_az_alt_z),
            float(az),     float(slope_zx), float(slope_zy), float(slope_max), float(flat),         float(cos_alt_z),
            zt ? 1.0f : 0.0f};
  }
};

/// Hillshade value before the byte conversion (gdaldem's formulas; see render_window.clh).
inline double shade(const double* v, Shading s, const ShadeParams& p) {
  const double gx = p.zt ? zt_x(v) : horn_x(v), gy = p.zt ? zt_y(v) : horn_y(v);
  const double x = gx * p.inv_ew, y = gy * p.inv_ns, xx_yy = x * x + y * y, zs = p.zs;
  if (s == Shading::Multidirectional) {
    if (xx_yy == 0.0) return 1.0 + 254.0 * p.sin_alt;
    const double s127 = 127.0 * p.sin_alt, c127 = 127.0 * p.cos_alt_z, c225 = c127 * std::cos(225.0 * M_PI / 180.0);
    const double v225 = std::max(0.0, s127 + (x - y) * c225), v270 = std::max(0.0, s127 - x * c127);
    const double v315 = std::max(0.0, s127 + (x + y) * c225), v360 = std::max(0.0, s127 - y * c127);
    const double w225 = 0.5 * xx_yy - x * y, w270 = x * x, w315 = xx_yy - w225, w360 = y * y;
    return 1.0 + (w225 * v225 + w270 * v270 + w315 * v315 + w360 * v360) / xx_yy / std::sqrt(1.0 + zs * zs * xx_yy);
  }
  if (s == Shading::Igor) {
    const double slope_deg = std::atan(std::sqrt(xx_yy) * zs) * 180.0 / M_PI;
    const double aspect = std::atan2(gy * -p.inv_ns, gx * p.inv_ew);
    auto norm = [](double a) {
      a = std::fmod(a, 2 * M_PI);
      return a < 0 ? a + 2 * M_PI : a;
    };
    double diff = std::abs(norm(aspect) - norm(1.5 * M_PI - p.az));
    if (diff > M_PI) diff = 2 * M_PI - diff;
    return 255.0 * (1.0 - (slope_deg / 90.0) * (1.0 - diff / M_PI));
  }
  const double num = p.sin_alt - (y * p.cos_az_alt_z - x * p.sin_az_alt_z), den = std::sqrt(1.0 + zs * zs * xx_yy);
  if (s == Shading::Combined) {
    const double cang = std::acos(std::clamp(num / den, -1.0, 1.0));
    const double c = 1.0 - cang * std::atan(std::sqrt(zs * zs * xx_yy)) / (M_PI * M_PI / 4.0);
    return c <= 0.0 ? 1.0 : 1.0 + 254.0 * c;
  }
  const double c254 = 254.0 * num / den;
  return c254 <= 0.0 ? 1.0 : 1.0 + c254;
}

/// gdaldem's Byte conversion: (GByte)(v + 0.5), clamped.
inline uint8_t to_byte(double v) { return uint8_t(std::clamp(std::floor(v + 0.5), 0.0, 255.0)); }

inline double slope(const double* v, const ShadeParams& p, bool percent) {
  // The sums in float as gdaldem adds its float window (as the aspect's): steep, rough cells
  // otherwise differ from gdaldem by a few 1e-4 relative.
  float f[9];
  for (int k = 0; k < 9; ++k) f[k] = float(v[k]);
  const float sx = p.zt ? f[3] - f[5] : (f[0] + f[3] + f[3] + f[6]) - (f[2] + f[5] + f[5] + f[8]);
  const float sy = p.zt ? f[7] - f[1] : (f[6] + f[7] + f[7] + f[8]) - (f[0] + f[1] + f[1] + f[2]);
  const double gx = double(sx) * p.slope_zx, gy = double(sy) * p.slope_zy;
  const double g = std::sqrt(gx * gx + gy * gy);
  return percent ? 100.0 * g : std::atan(g) * 180.0 / M_PI;
}

/// Rows of a strip of `rows` starting at y0, and the grid rows its windows read.
struct Strip {
  int y0, rows, r0, r1;
};
inline std::vector<Strip> strips(int height, int strip_rows) {
  std::vector<Strip> out;
  const int n = std::max(1, strip_rows);
  for (int y0 = 0; y0 < height; y0 += n) {
    const int rows = std::min(n, height - y0);
    out.push_back({y0, rows, std::max(0, y0 - 1), std::min(height, y0 + rows + 1)});
  }
  return out;
}

}  // namespace terracl::render::detail
