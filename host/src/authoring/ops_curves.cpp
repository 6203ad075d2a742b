// SPDX-License-Identifier: Apache-2.0
// Landform curves (paper section 4.2, figure 4): a sketched polyline with a cross-section.
// crest, cliff and river put elevation constraints on the curve plus a profile gradient on the
// side(s); free_crest, fault and ravine are gradient-only. Profile gradients are added to the field,
// so they superpose additively (crossing faults add up); elevation constraints replace each other.
//
// Every curve has a cross-section in metres: `width` (the full width, 2 r; the old `radius` = r is
// still read), `profile`, `floor` (a flat floor/top, also the width of a constrained curve's band),
// `taper` (the amplitude fades to 0 over this arc length at both ends) and `smooth` (a centripetal
// Catmull-Rom spline through the points). Defaults scale with the cell size and the feature's
// relief, so that no default feature is narrower than kMinCells cells.
#include "authoring/curve_shape.hpp"
#include "authoring/ops_landforms.hpp"
#include "authoring/state.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace terracl::edit {

namespace {
// Half-widths of at least this many cells keep every profile's full width at half maximum (0.41 r
// for the sharpest, `sharp`) and a cliff's face (0.35 r) at >= 3 cells.
constexpr double kMinHalfWidthCells = 9;
}  // namespace

double min_half_width(const Grid& g) { return kMinHalfWidthCells * std::max(g.cell_x, g.cell_y); }

CurveShape parse_curve_shape(Params& p, const std::string& def_profile, const std::vector<std::string>& profiles,
                             bool def_taper) {
  CurveShape c;
  c.pts = p.points("points", 2);
  const bool has_r = p.has("radius"), has_w = p.has("width");
  if (has_r && has_w)
    param_error(p.where("width"),
                "give either width (the full width of the cross-section, m) or radius (half of it), not both; "
                "the constrained band of a crest, cliff or river is now `floor`");
  if (has_w) c.radius = 0.5 * p.hlength("width", {}, 0, true);
  if (has_r) c.radius = p.hlength("radius", {}, 0, true);
  c.floor = p.hlength("floor", 0.0);
  if (!profiles.empty()) {
    const std::string prof = p.choice("profile", def_profile, profiles);
    if (prof == "round") c.profile = Profile::Round;
    else if (prof == "sharp") c.profile = Profile::Sharp;
    else if (prof == "v") c.profile = Profile::V;
    else if (prof == "u") c.profile = Profile::U;
    else if (prof == "flat") c.profile = Profile::U, c.flat = true;
  }
  if (p.has("taper")) c.taper = p.hlength("taper", 0.0);
  else c.taper = def_taper ? -1.0 : 0.0;  // -1: the half-width, once known
  c.smooth = p.boolean("smooth", false);
  return c;
}

double CurveShape::resolve_radius(const Grid& g, double amplitude, double per_metre) const {
  if (radius > 0) return radius;
  return std::max(min_half_width(g), per_metre * std::abs(amplitude));
}

std::vector<Vec3> CurveShape::path(const Grid& g, double r) const {
  if (!smooth || pts.size() < 3) return pts;
  std::vector<double> z;
  for (const auto& v : pts) z.push_back(v.z);
  const bool with_z = !std::isnan(pts[0].z);
  std::vector<double> zs;
  const double step = std::max(0.125 * r, 1.5 * std::max(g.cell_x, g.cell_y));
  const auto xy2 = catmull_rom(xy(pts), step, with_z ? z : std::vector<double>{}, &zs);
  std::vector<Vec3> out;
  for (size_t i = 0; i < xy2.size(); ++i) out.push_back({xy2[i].x, xy2[i].y, with_z ? zs[i] : pts[0].z});
  return out;
}

Primitive CurveShape::primitive(const std::vector<Vec3>& path_pts, double r, Profile prof, double amplitude) const {
  Primitive pr;
  pr.shape = PrimitiveShape::Polyline;
  pr.points = xy(path_pts);
  pr.radius = r;
  pr.profile = prof;
  pr.profile_amplitude = amplitude;
  pr.floor_half_width = flat && floor <= 0 ? r / 3 : 0.5 * floor;
  const double t = taper < 0 ? r : taper;
  pr.taper_start = pr.taper_end = t;
  pr.smooth = smooth && pts.size() >= 3;
  return pr;
}

void release_near_polyline(EditState& s, const std::vector<Vec3>& pts, double half) {
  const Grid& g = s.grid();
  auto& hard = s.hard();
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const Vec3 &a = pts[i], &b = pts[i + 1];
    const int x0 = std::max(0, cell_index(std::floor((std::min(a.x, b.x) - half) / g.cell_x)));
    const int x1 = std::min(g.width - 1, cell_index(std::ceil((std::max(a.x, b.x) + half) / g.cell_x)));
    const int y0 = std::max(0, cell_index(std::floor((std::min(a.y, b.y) - half) / g.cell_y)));
    const int y1 = std::min(g.height - 1, cell_index(std::ceil((std::max(a.y, b.y) + half) / g.cell_y)));
    const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double px = x * g.cell_x, py = y * g.cell_y;
        const double t = l2 > 0 ? std::clamp(((px - a.x) * ux + (py - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
        if (std::hypot(px - a.x - t * ux, py - a.y - t * uy) <= half)
          hard[size_t(y) * g.width + x] = std::numeric_limits<float>::quiet_NaN();
      }
  }
  s.changed();
}

namespace {

// Vertices with an elevation each: from [x, y, z] points, else from "elevation".
void with_elevation(Params& p, std::vector<Vec3>& pts) {
  size_t with_z = 0;
  for (const auto& v : pts) with_z += std::isnan(v.z) ? 0 : 1;
  if (with_z != 0 && with_z != pts.size()) param_error(p.where("points"), "give z for every point or for none");
  if (with_z == 0) {
    const double z = p.vlength("elevation");
    for (auto& v : pts) v.z = z;
  } else if (p.has("elevation")) {
    param_error(p.where("elevation"), "the points already carry elevations [x, y, z]");
  }
}

// Mean elevation of the terrain under the curve's vertices (the crest's local relief), read from
// the last solution (or the real base before the first solve) without a new solve: an estimate
// that misses the operations since then, where the solve it replaces cost 50-300 ms per crest (a
// studio replay of 30 crests re-solved 30 times). Only a session without either solves first.
double terrain_under(EditState& s, const std::vector<Vec3>& pts) {
  const Heightfield* last = s.last_solution();
  const Heightfield& h = last ? *last : s.height();
  double sum = 0;
  int n = 0;
  for (const auto& v : pts) {
    const int x = std::clamp(int(std::lround(v.x / s.grid().cell_x)), 0, h.width - 1);
    const int y = std::clamp(int(std::lround(v.y / s.grid().cell_y)), 0, h.height - 1);
    const float z = h.at(x, y);
    if (std::isfinite(z)) sum += z, ++n;
  }
  return n ? sum / n : 0.0;
}

Operation parse_crest(Params& p) {
  if (is_relative(p, "points")) return relative_crest(p);
  CurveShape c = parse_curve_shape(p, "sharp", {"sharp", "round", "v", "u", "flat"}, false);
  with_elevation(p, c.pts);
  const std::optional<double> height = p.has("height") ? std::optional<double>(p.vlength("height")) : std::nullopt;
  return [=](EditState& s) {
    // Default height: the crest's relief above the terrain under it (so the flanks meet the
    // constrained crest line instead of leaving a one-cell wall), else 0.3 r.
    double h = 0;
    if (height) h = *height;
    else {
      double zc = 0;
      for (const auto& v : c.pts) zc += v.z;
      h = zc / c.pts.size() - terrain_under(s, c.pts);
      if (!(h > 0)) h = 0.3 * c.resolve_radius(s.grid(), 0, 0);
    }
    const double r = c.resolve_radius(s.grid(), h, 1.5);
    const auto path = c.path(s.grid(), r);
    Primitive pr = c.primitive(path, r, c.profile, h);
    pr.crest_round = 0;  // the line is pinned: a rounded top beside it rose above the crest
    add_profile_gradient(s.device(), s.buffers(), {pr});
    rasterize_polyline(s, path, c.floor);
    s.changed();
  };
}

Operation parse_cliff(Params& p) {
  if (is_relative(p, "points")) return relative_cliff(p);
  CurveShape c = parse_curve_shape(p, "", {}, false);
  with_elevation(p, c.pts);
  const double height = p.vlength("height");
  if (!(height > 0)) param_error(p.where("height"), fmt::format("expected a drop > 0 m, got {}", height));
  const std::string side = p.choice("side", "right", {"right", "left"});
  const double scree = p.number("scree", 0.35, 0.0, 0.95);
  const double face = p.number("face", 0.3, 0.05, 1.0);
  return [=](EditState& s) {
    const double r = c.resolve_radius(s.grid(), height, 2.0);
    const auto path = c.path(s.grid(), r);
    std::vector<Vec3> dir = path;
    if (side == "left") std::reverse(dir.begin(), dir.end());
    Primitive pr = c.primitive(dir, r, Profile::Drop, height);
    pr.scree = scree;
    pr.face_fraction = face;
    add_profile_gradient(s.device(), s.buffers(), {pr});
    rasterize_polyline(s, path, c.floor);
    s.changed();
  };
}

// The terrain under the river (last solution, else the real base) minus the river's z along its
// path, at least 0: the bank height at which the valley's walls meet the terrain at r. A bank higher than the cut raises everything beyond r by the excess (the
// profile's rise is added to the terrain's own slope), which on a plain stood as a raised lobe.
std::vector<double> banks_to_terrain(EditState& s, const std::vector<Vec3>& path, double r) {
  const Heightfield* last = s.last_solution();
  const Heightfield& h = last ? *last : s.height();
  const Grid& g = s.grid();
  std::vector<double> cut(path.size(), 0.0), arc(path.size(), 0.0), w(path.size(), 0.0);
  for (size_t i = 0; i < path.size(); ++i) {
    if (i) arc[i] = arc[i - 1] + std::hypot(path[i].x - path[i - 1].x, path[i].y - path[i - 1].y);
    const double fx = std::clamp(path[i].x / g.cell_x, 0.0, h.width - 1.0);
    const double fy = std::clamp(path[i].y / g.cell_y, 0.0, h.height - 1.0);
    const int x0 = std::max(0, std::min(int(fx), h.width - 2)), y0 = std::max(0, std::min(int(fy), h.height - 2));
    const int x1 = std::min(x0 + 1, h.width - 1), y1 = std::min(y0 + 1, h.height - 1);
    const double tx = fx - x0, ty = fy - y0;
    const double z = (1 - ty) * ((1 - tx) * h.at(x0, y0) + tx * h.at(x1, y0)) + ty * ((1 - tx) * h.at(x0, y1) + tx * h.at(x1, y1));
    if (std::isfinite(z)) cut[i] = z - path[i].z, w[i] = 1;
  }
  // The least cut within r/4, then its mean within r/4: smooth along the arc (a jumping amplitude
  // draws streaks across the banks) and never above the cut at the vertex itself (every window of
  // the mean contains the vertex), so the banks stay at or below the terrain.
  auto window = [&](size_t i, auto&& f) {
    for (size_t j = i; j-- > 0 && arc[i] - arc[j] <= 0.25 * r;) f(j);
    for (size_t j = i; j < path.size() && arc[j] - arc[i] <= 0.25 * r; ++j) f(j);
  };
  std::vector<double> lo(path.size(), 0.0), out(path.size(), 0.0);
  for (size_t i = 0; i < path.size(); ++i) {
    double m = std::numeric_limits<double>::infinity();
    window(i, [&](size_t j) { if (w[j] > 0) m = std::min(m, cut[j]); });
    lo[i] = std::isfinite(m) ? std::max(0.0, m) : 0.0;
  }
  for (size_t i = 0; i < path.size(); ++i) {
    double sum = 0, n = 0;
    window(i, [&](size_t j) { sum += lo[j], n += 1; });
    out[i] = sum / n;
  }
  return out;
}

Operation parse_river(Params& p) {
  if (is_relative(p, "points")) return relative_river(p);
  CurveShape c = parse_curve_shape(p, "round", {"round", "u", "v", "flat"}, false);
  with_elevation(p, c.pts);
  // `bank_height`: metres, or "terrain" (per vertex: the depth of the river below the terrain).
  const bool to_terrain = p.has("bank_height") && p.raw("bank_height").is_string() && p.string("bank_height") == "terrain";
  const std::optional<double> bank =
      !to_terrain && p.has("bank_height") ? std::optional<double>(p.vlength("bank_height")) : std::nullopt;
  if (bank && *bank < 0) param_error(p.where("bank_height"), "expected >= 0 m (banks rise away from the river) or \"terrain\"");
  return [=](EditState& s) {
    const double r = c.resolve_radius(s.grid(), bank.value_or(0), 0.0);
    auto path = c.path(s.grid(), r);
    if (to_terrain) {
      // Vertices every r/4 at most (z linear along each piece, as the bed is rasterized), so the
      // bank height follows the terrain between sparse hand-placed points.
      std::vector<Vec3> dense{path.front()};
      for (size_t i = 1; i < path.size(); ++i) {
        const Vec3 &u = path[i - 1], &v = path[i];
        const int n = std::max(1, int(std::ceil(std::hypot(v.x - u.x, v.y - u.y) / (0.25 * r))));
        for (int k = 1; k <= n; ++k) {
          const double t = double(k) / n;
          dense.push_back({u.x + t * (v.x - u.x), u.y + t * (v.y - u.y), u.z + t * (v.z - u.z)});
        }
      }
      path = std::move(dense);
      Primitive pr = c.primitive(path, r, c.profile, 1.0);
      for (double b : banks_to_terrain(s, path, r)) pr.amplitude.push_back(-b);
      add_profile_gradient(s.device(), s.buffers(), {pr});
    } else {
      const double b = bank.value_or(0.1 * r);
      add_profile_gradient(s.device(), s.buffers(), {c.primitive(path, r, c.profile, -b)});
    }
    rasterize_polyline(s, path, c.floor);
    s.changed();
  };
}

// Gradient-only curves. Per-vertex z (if given) scales the amplitude along the curve.
struct GradientCurve {
  CurveShape c;
  std::vector<double> amp;  // per-vertex amplitudes (metres), or empty
  double amplitude = 1;     // uniform amplitude (metres) when amp is empty
};

GradientCurve parse_gradient_curve(Params& p, const std::string& amp_key, double sign, CurveShape c) {
  GradientCurve g;
  size_t with_z = 0;
  for (const auto& v : c.pts) with_z += std::isnan(v.z) ? 0 : 1;
  if (with_z != 0 && with_z != c.pts.size()) param_error(p.where("points"), "give z for every point or for none");
  if (with_z) {
    for (const auto& v : c.pts) g.amp.push_back(sign * v.z);
    if (p.has(amp_key)) param_error(p.where(amp_key), "the points already carry per-vertex values [x, y, z]");
  } else {
    g.amplitude = sign * p.vlength(amp_key);
  }
  g.c = std::move(c);
  return g;
}

Primitive gradient_primitive(const GradientCurve& g, const Grid& grid, double per_metre, Profile prof) {
  double peak = std::abs(g.amplitude);
  for (double a : g.amp) peak = std::max(peak, std::abs(a));
  const double r = g.c.resolve_radius(grid, peak, per_metre);
  CurveShape c = g.c;
  if (!g.amp.empty())
    for (size_t i = 0; i < c.pts.size(); ++i) c.pts[i].z = g.amp[i];
  const auto path = c.path(grid, r);
  Primitive pr = c.primitive(path, r, prof, g.amp.empty() ? g.amplitude : 1.0);
  if (!g.amp.empty())
    for (const auto& v : path) pr.amplitude.push_back(v.z);
  return pr;
}

Operation parse_free_crest(Params& p) {
  CurveShape c = parse_curve_shape(p, "round", {"round", "sharp", "v", "u", "flat"}, true);
  const GradientCurve g = parse_gradient_curve(p, "height", 1.0, std::move(c));
  return [=](EditState& s) {
    add_profile_gradient(s.device(), s.buffers(), {gradient_primitive(g, s.grid(), 2.0, g.c.profile)});
    s.changed();
  };
}

Operation parse_fault(Params& p) {
  CurveShape c = parse_curve_shape(p, "", {}, false);
  const GradientCurve g = parse_gradient_curve(p, "throw", 1.0, std::move(c));
  return [=](EditState& s) {
    add_profile_gradient(s.device(), s.buffers(), {gradient_primitive(g, s.grid(), 1.0, Profile::Step)});
    s.changed();
  };
}

// A ravine deepens downstream (from the first point to the last): without per-vertex depths its
// depth grows linearly along the stroke from `depth_start` [0.35 depth] to `depth`. It cuts through
// the constrained rims it crosses (their hard cells within half its half-width r are released) unless
// `"cut_rims": false`, and it exits at its last point (`exit`, below) instead of ending in a pit.
Operation parse_ravine(Params& p) {
  CurveShape c = parse_curve_shape(p, "v", {"v", "sharp", "u", "round", "flat"}, true);
  GradientCurve g = parse_gradient_curve(p, "depth", -1.0, std::move(c));
  if (g.amp.empty()) {
    const double start = p.has("depth_start") ? -p.vlength("depth_start") : 0.35 * g.amplitude;
    std::vector<double> arc{0};
    for (size_t i = 1; i < g.c.pts.size(); ++i)
      arc.push_back(arc.back() + std::hypot(g.c.pts[i].x - g.c.pts[i - 1].x, g.c.pts[i].y - g.c.pts[i - 1].y));
    for (double a : arc) g.amp.push_back(start + (g.amplitude - start) * (arc.back() > 0 ? a / arc.back() : 1.0));
  } else if (p.has("depth_start")) {
    param_error(p.where("depth_start"), "the points already carry per-vertex depths [x, y, z]");
  }
  const bool cut = p.boolean("cut_rims", true);
  const std::optional<double> exit =
      p.has("exit") ? std::optional<double>(p.hlength("exit", 0.0)) : std::nullopt;
  const bool own_taper = p.has("taper");
  return [=](EditState& s) {
    Primitive pr = gradient_primitive(g, s.grid(), 2.0, g.c.profile);
    // The open (downstream) end exits: the stroke goes on along its end tangent for `exit` [3 r],
    // its depth fading to zero over that run, instead of closing in a bowl of radius r (a pit as
    // deep as the ravine, wherever the ground does not fall faster than the bowl's wall rises).
    const double run = exit.value_or(3.0 * pr.radius);
    const size_t n = pr.points.size();
    if (run > 0 && n >= 2) {
      const Vec2 a = pr.points[n - 2], b = pr.points[n - 1];
      const double l = std::hypot(b.x - a.x, b.y - a.y);
      if (l > 0) {
        pr.points.push_back({b.x + (b.x - a.x) / l * run, b.y + (b.y - a.y) / l * run});
        if (!pr.amplitude.empty()) pr.amplitude.push_back(pr.amplitude.back());
        pr.taper_end = own_taper ? std::max(pr.taper_end, run) : run;
      }
    }
    add_profile_gradient(s.device(), s.buffers(), {pr});
    if (cut && s.hard_count() > 0) {
      std::vector<Vec3> line;
      for (const auto& v : pr.points) line.push_back({v.x, v.y, 0.0});
      release_near_polyline(s, line, pr.radius);
    }
    s.changed();
  };
}

}  // namespace

void add_curve_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"crest", "elevation constraints on a curve plus flanks on both sides", parse_crest});
  ops.push_back({"cliff", "elevation constraints on the cliff top plus a steep face and a scree apron on one side", parse_cliff});
  ops.push_back({"river", "elevation constraints along a river plus gently rising banks", parse_river});
  ops.push_back({"free_crest", "a ridge made of gradients only (no elevation constraint)", parse_free_crest});
  ops.push_back({"fault", "a step of a given throw across a curve, gradients only (faults add up)", parse_fault});
  ops.push_back({"ravine", "a valley deepening downstream, gradients only; cuts through constrained rims", parse_ravine});
}

}  // namespace terracl::edit
