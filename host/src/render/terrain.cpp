// SPDX-License-Identifier: Apache-2.0
// Host reference of gdaldem's value rasters (kernels/render_terrain.cl): slope, aspect, TRI, TPI
// and roughness in double precision, with gdaldem's window rules (render_window.hpp), and GRASS
// r.slope.aspect's profile and tangential curvatures on the same windows.
#include <terracl/error.hpp>
#include <terracl/render.hpp>

#include "render/render_internal.hpp"
#include "render/render_window.hpp"

namespace terracl::render {

namespace {

double terrain_value(const double* v, const Options& o, const detail::ShadeParams& p) {
  switch (o.mode) {
    case Mode::Slope:
      return detail::slope(v, p, o.slope_percent);
    case Mode::Aspect: {
      // Horn's sums in float as gdaldem adds its float window: on near-flat cells the angle is
      // ill-conditioned, and double sums differ from gdaldem's by degrees there.
      float f[9];
      for (int k = 0; k < 9; ++k) f[k] = float(v[k]);
      const double hx = p.zt ? double(f[3] - f[5]) : double((f[0] + f[3] + f[3] + f[6]) - (f[2] + f[5] + f[5] + f[8]));
      const double hy = p.zt ? double(f[7] - f[1]) : double((f[6] + f[7] + f[7] + f[8]) - (f[0] + f[1] + f[1] + f[2]));
      if (hx == 0.0 && hy == 0.0) return o.zero_for_flat ? 0.0 : NAN;
      double a = std::atan2(hy * -p.inv_ns, hx * p.inv_ew) * 180.0 / M_PI;
      if (!o.aspect_trigonometric)
        a = a > 90.0 ? 450.0 - a : 90.0 - a;
      else if (a < 0.0)
        a += 360.0;
      return a == 360.0 ? 0.0 : a;
    }
    case Mode::TRI: {
      double s = 0;
      for (int k = 0; k < 9; ++k)
        s += o.tri_alg == TriAlg::Wilson ? std::abs(v[k] - v[4]) : (v[k] - v[4]) * (v[k] - v[4]);
      return o.tri_alg == TriAlg::Wilson ? s / 8.0 : std::sqrt(s);
    }
    case Mode::TPI:
      return v[4] - (v[0] + v[1] + v[2] + v[3] + v[5] + v[6] + v[7] + v[8]) / 8.0;
    case Mode::Roughness:
      return *std::max_element(v, v + 9) - *std::min_element(v, v + 9);
    case Mode::ProfileCurvature:
    case Mode::TangentialCurvature:
      return detail::curvature(v, 1.0 / p.inv_ew, -1.0 / p.inv_ns, p.zs * (p.zt ? 2.0 : 8.0),
                               o.mode == Mode::ProfileCurvature);
    default:
      fail("render", "mode has no value raster (expected slope|aspect|tri|tpi|roughness|profile-curvature|tangential-curvature)");
  }
}

}  // namespace

Heightfield values(const Heightfield& h, const Options& opt) {
  check_options(h, opt);
  if (!is_value_mode(opt.mode)) fail("render", "mode has no value raster (expected slope|aspect|tri|tpi|roughness|profile-curvature|tangential-curvature)");
  Heightfield out = value_raster_like(h, opt);
  const detail::ShadeParams p(h, opt);
  double w[9];
  for (int y = 0; y < h.height; ++y) {
    for (int x = 0; x < h.width; ++x)
      out.at(x, y) = detail::window(h, x, y, opt.compute_edges, w) ? float(terrain_value(w, opt, p)) : NAN;
    if ((y & 255) == 255) report_progress(opt.progress, "render", double(y + 1) / h.height, "terrain values");
  }
  return out;
}

Heightfield value_raster_like(const Heightfield& h, const Options& opt) {
  Heightfield out;
  out.width = h.width;
  out.height = h.height;
  out.z.assign(h.size(), NAN);
  out.georef = h.georef;
  out.georef.nodata = -9999.0;  // gdaldem's nodata for float products
  out.metadata = h.metadata;
  const char* unit = "m";
  const char* what = "";
  switch (opt.mode) {
    case Mode::Slope:
      unit = opt.slope_percent ? "percent" : "degrees", what = "slope";
      break;
    case Mode::Aspect:
      unit = "degrees", what = opt.aspect_trigonometric ? "aspect (counter-clockwise from east)" : "aspect (azimuth)";
      break;
    case Mode::TRI:
      what = opt.tri_alg == TriAlg::Wilson ? "TRI (Wilson)" : "TRI (Riley)";
      break;
    case Mode::TPI:
      what = "TPI";
      break;
    case Mode::ProfileCurvature:
    case Mode::TangentialCurvature:
      unit = "1/m", what = opt.mode == Mode::ProfileCurvature ? "profile curvature" : "tangential curvature";
      break;
    default:
      what = "roughness";
  }
  out.georef.vertical_units = unit;
  out.metadata["terracl:quantity"] = what;
  return out;
}

}  // namespace terracl::render
