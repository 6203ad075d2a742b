// SPDX-License-Identifier: Apache-2.0
#include "authoring/landform_shapes.hpp"

#include <terracl/amplify.hpp>  // parallel_for

#include <algorithm>
#include <cmath>

namespace terracl::edit {
namespace {

double smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}
Vec2 rotate(Vec2 v, double a) { return {v.x * std::cos(a) - v.y * std::sin(a), v.x * std::sin(a) + v.y * std::cos(a)}; }
Vec2 unit(Vec2 v) {
  const double l = std::max(1e-12, std::hypot(v.x, v.y));
  return {v.x / l, v.y / l};
}
double cell_of(const Grid& g) { return std::max(g.cell_x, g.cell_y); }

// Linear interpolation of per-stroke-vertex values at arc length `a` (one value: constant).
double along(const std::vector<double>& v, const std::vector<double>& arc, double a) {
  if (v.size() == 1 || arc.size() < 2) return v.front();
  if (a <= arc.front()) return v.front();
  for (size_t i = 1; i < arc.size(); ++i)
    if (a <= arc[i]) {
      const double t = arc[i] > arc[i - 1] ? (a - arc[i - 1]) / (arc[i] - arc[i - 1]) : 1.0;
      return v[i - 1] + t * (v[i] - v[i - 1]);
    }
  return v.back();
}

// A curved line from `p` along `dir`: it bends by up to `bend` radians and wanders sideways.
std::vector<Vec2> branch_path(Vec2 p, Vec2 dir, double len, double bend, double wobble, uint32_t seed) {
  std::vector<Vec2> pts{p};
  const int n = 8;
  Vec2 d = unit(dir), q = p;
  for (int k = 1; k <= n; ++k) {
    d = rotate(d, bend / n);
    q = {q.x + d.x * len / n, q.y + d.y * len / n};
    pts.push_back(q);
  }
  return wander(pts, wobble * len, 0.6 * len, 2, seed);
}

// A line's wander from the scale of the whole landform down: fBm of gain 1/2 whose first octave's
// wavelength is a third of the line's length (at least `lo`, at most `hi`), with amplitude `ratio`
// of that wavelength (fbm is normalised: typical offsets are about a fifth of it), and octaves down
// to a quarter of `lo`. Each octave's amplitude is the same share of its wavelength, so a long
// stroke bends at the scale of the whole landform as a short one does at the scale of its parts.
std::vector<Vec2> wander_scales(const std::vector<Vec2>& pts, double ratio, double lo, double hi, uint32_t seed) {
  if (pts.size() < 2 || !(lo > 0)) return pts;
  const double top = std::clamp(arc_lengths(pts).back() / 3, lo, std::max(lo, hi));
  const int octaves = 3 + int(std::floor(std::log2(top / lo) + 1e-9));
  return wander(pts, ratio * top, top, std::min(octaves, 9), seed);
}

// Two passes of a separable box blur of radius r cells (about a Gaussian of sigma 0.8 r): age
// rounds crests and softens walls.
void soften(ShapeRaster& s, int r) {
  if (r < 1 || s.box.empty()) return;
  const int W = s.box.w, H = s.box.h;
  std::vector<float> tmp(s.v.size());
  for (int pass = 0; pass < 2; ++pass) {
    for (int y = 0; y < H; ++y) {
      double acc = 0;
      int n = 0;
      for (int x = -r; x <= r; ++x)
        if (x >= 0 && x < W) acc += s.v[size_t(y) * W + x], ++n;
      for (int x = 0; x < W; ++x) {
        tmp[size_t(y) * W + x] = float(acc / std::max(1, n));
        const int out = x - r, in = x + r + 1;
        if (out >= 0) acc -= s.v[size_t(y) * W + out], --n;
        if (in < W) acc += s.v[size_t(y) * W + in], ++n;
      }
    }
    for (int x = 0; x < W; ++x) {
      double acc = 0;
      int n = 0;
      for (int y = -r; y <= r; ++y)
        if (y >= 0 && y < H) acc += tmp[size_t(y) * W + x], ++n;
      for (int y = 0; y < H; ++y) {
        s.v[size_t(y) * W + x] = float(acc / std::max(1, n));
        const int out = y - r, in = y + r + 1;
        if (out >= 0) acc -= tmp[size_t(out) * W + x], --n;
        if (in < H) acc += tmp[size_t(in) * W + x], ++n;
      }
    }
  }
}

// Detail whose amplitude follows the shape and fades to nothing at its highest point (a crest
// drawn at a height stays at that height).
void detail_below_top(ShapeRaster& s, const Grid& g, double amp, double wavelength, uint32_t seed) {
  float top = 0;
  for (float v : s.v) top = std::max(top, v);
  if (!(top > 0)) return;
  ShapeRaster d = s;
  add_relief_detail(d, g, amp, wavelength, seed);
  for (size_t i = 0; i < s.v.size(); ++i) {
    const double e = std::min(1.0, 4.0 * (1.0 - s.v[i] / top));
    s.v[i] = float(s.v[i] + e * (d.v[i] - s.v[i]));
  }
}

// Rock bands of a wall: height fraction e(t) for t in [0, 1] across the wall (0 at its foot, 1 at
// its top). Each band is a bench (hard caprock: a wide ledge and a near-vertical cliff; soft: a
// narrow ledge and a steep slope), with thicknesses drawn unevenly.
struct Bands {
  std::vector<double> t, e;  // boundaries in t and in height fraction, 0 .. 1
  std::vector<bool> hard;
  double operator()(double x) const {
    x = std::clamp(x, 0.0, 1.0);
    if (t.size() < 2) return x;
    size_t k = 0;
    while (k + 2 < t.size() && x > t[k + 1]) ++k;
    const double fr = (x - t[k]) / std::max(1e-9, t[k + 1] - t[k]);
    const double bench = hard[k] ? 0.55 : 0.25;
    const double r = std::clamp((fr - bench) / (1 - bench), 0.0, 1.0);
    return e[k] + (e[k + 1] - e[k]) * (hard[k] ? std::sqrt(r) : smoothstep(r));
  }
};
Bands make_bands(int n, Rng& rng) {
  Bands b;
  if (n <= 0) return b;
  std::vector<double> wt(n), wh(n);
  double st = 0, sh = 0;
  for (int k = 0; k < n; ++k) st += wt[k] = rng.uniform(0.5, 1.6), sh += wh[k] = rng.uniform(0.4, 1.8);
  b.t.push_back(0), b.e.push_back(0);
  for (int k = 0; k < n; ++k) {
    b.t.push_back(b.t.back() + wt[k] / st), b.e.push_back(b.e.back() + wh[k] / sh);
    b.hard.push_back(k % 2 == 0 ? rng.uniform() < 0.8 : rng.uniform() < 0.3);
  }
  b.t.back() = b.e.back() = 1.0;
  return b;
}

// Nearest point of a polyline for every cell within `reach` of it: distance, side (+1 on the right
// of the direction of travel on a north-up map, -1 on the left) and arc length there.
struct Nearest {
  ShapeRaster dist, side, arc;
};
Nearest nearest_on(const Grid& g, const std::vector<Vec2>& pts, const Box& box, double reach) {
  Nearest n{ShapeRaster(box), ShapeRaster(box), ShapeRaster(box)};
  std::fill(n.dist.v.begin(), n.dist.v.end(), std::numeric_limits<float>::infinity());
  const auto arc = arc_lengths(pts);
  std::vector<Box> boxes;
  for (size_t i = 0; i + 1 < pts.size(); ++i) boxes.push_back(box_around(g, {pts[i], pts[i + 1]}, reach));
  // Rows are independent: each thread takes a band of them and every piece that reaches it.
  parallel_for(size_t(box.h), 0, [&](size_t r0, size_t r1) {
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
      const Vec2 a = pts[i], b = pts[i + 1];
      const Box& bb = boxes[i];
      const int x0 = std::max(bb.x0, box.x0), x1 = std::min(bb.x0 + bb.w, box.x0 + box.w);
      const int y0 = std::max(bb.y0, box.y0 + int(r0)), y1 = std::min(bb.y0 + bb.h, box.y0 + int(r1));
      const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const double px = x * g.cell_x, py = y * g.cell_y;
          const double t = l2 > 0 ? std::clamp(((px - a.x) * ux + (py - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
          const double dx = px - a.x - t * ux, dy = py - a.y - t * uy, d = std::hypot(dx, dy);
          if (d < n.dist.at(x, y)) {
            n.dist.at(x, y) = float(d);
            n.side.at(x, y) = (ux * dy - uy * dx) >= 0 ? 1.0f : -1.0f;
            n.arc.at(x, y) = float(arc[i] + t * std::sqrt(l2));
          }
        }
    }
  });
  return n;
}

}  // namespace

ShapeRaster ridge_system(const Grid& g, const RidgeParams& p) {
  const double W = p.width, cell = cell_of(g);
  const double rough = p.look.roughness, age = p.look.age;
  const double sharp = p.sharpness >= 0 ? p.sharpness : std::clamp(1.0 - 0.8 * age, 0.0, 1.0);
  Rng rng(p.look.seed);
  const auto stroke_arc = arc_lengths(p.stroke);
  double hmax = 0;
  for (double h : p.height) hmax = std::max(hmax, h);
  const bool peak = p.stroke.size() < 2 || stroke_arc.back() < 2 * cell;
  std::vector<RidgeLine> lines;
  RidgeLine main;
  if (!peak) {
    const auto base = resample(p.stroke, std::max(W / 6, cell));
    const auto base_arc = arc_lengths(base);
    main.pts = p.free_line ? wander_scales(base, 0.2 + 0.2 * rough, 1.6 * W, 12 * W, p.look.seed + 1) : base;
    const double L = base_arc.back();
    const double taper = p.taper >= 0 ? p.taper : std::min(0.8 * W, L / 3);
    for (size_t i = 0; i < main.pts.size(); ++i) {
      const double a = base_arc[i];
      // Summits and saddles along a range.
      const double relief = p.free_line ? 1 + (0.2 + 0.25 * rough) * fbm(a / (1.3 * W), 3.7, 3, 0.5, p.look.seed + 2) : 1.0;
      const double end = taper > 0 ? smoothstep(std::min(a, L - a) / taper) : 1.0;
      main.h.push_back(along(p.height, stroke_arc, a * stroke_arc.back() / std::max(1e-9, L)) * relief * end);
      main.w.push_back(0.8 * W * (1 + 0.15 * fbm(a / (0.9 * W), 8.1, 2, 0.5, p.look.seed + 3)));
    }
  } else {
    const Vec2 c = p.stroke.front();
    main.pts = {c, {c.x + 0.01 * cell, c.y}};
    main.h = {p.height.front(), p.height.front()};
    main.w = {0.8 * W, 0.8 * W};
  }
  lines.push_back(main);

  // Spurs: down both flanks at uneven spacing, mostly alternating sides, bending as they descend;
  // the longer ones fork once. Their crests stay above the main flank, so the valleys between
  // them are the flank itself.
  std::function<void(Vec2, Vec2, double, double, double, int)> spur = [&](Vec2 at, Vec2 dir, double len, double h0,
                                                                           double w0, int level) {
    if (len < 3 * cell || h0 <= 0) return;
    RidgeLine s;
    s.pts = branch_path(at, dir, len, rng.uniform(-0.45, 0.45), 0.05 + 0.1 * rough, uint32_t(rng.next()));
    const int n = int(s.pts.size());
    const double fall = 1.1 + 0.4 * rng.uniform();
    for (int k = 0; k < n; ++k) {
      const double t = double(k) / (n - 1);
      s.h.push_back(h0 * std::pow(1 - t, fall));
      s.w.push_back(w0 * (1 - 0.45 * t));
    }
    lines.push_back(s);
    if (level >= 1) return;
    const int forks = (rng.uniform() < 0.65 * p.spurs ? 1 : 0) + (rng.uniform() < 0.25 * p.spurs ? 1 : 0);
    double side = rng.uniform() < 0.5 ? -1 : 1;
    for (int f = 0; f < forks; ++f, side = -side) {
      const double t = rng.uniform(0.25, 0.6);
      const int k = std::clamp(int(t * (n - 1)), 0, n - 2);
      const Vec2 tan = unit({s.pts[k + 1].x - s.pts[k].x, s.pts[k + 1].y - s.pts[k].y});
      spur(s.pts[k], rotate(tan, side * rng.uniform(0.5, 1.0)), (1 - t) * len * rng.uniform(0.5, 0.8),
           0.95 * s.h[k], 0.7 * s.w[k], level + 1);
    }
  };
  if (p.spurs > 0) {
    if (peak) {
      const int n = int(std::lround(4 + 3 * p.spurs + 2 * rng.uniform()));
      const double a0 = rng.uniform(0, 2 * M_PI);
      for (int k = 0; k < n; ++k) {
        const double a = a0 + 2 * M_PI * (k + rng.uniform(-0.3, 0.3)) / n;
        spur(main.pts.front(), {std::cos(a), std::sin(a)}, W * rng.uniform(0.8, 1.05), 0.97 * main.h.front(), 0.42 * W, 0);
      }
    } else {
      const auto arc = arc_lengths(main.pts);
      double side = rng.uniform() < 0.5 ? -1 : 1;
      for (double a = W * rng.uniform(0.2, 0.5) / p.spurs; a < arc.back(); a += W * rng.uniform(0.35, 0.75) / p.spurs) {
        size_t i = 0;
        while (i + 2 < main.pts.size() && arc[i + 1] < a) ++i;
        const Vec2 tan = unit({main.pts[i + 1].x - main.pts[i].x, main.pts[i + 1].y - main.pts[i].y});
        const double hc = main.h[i];
        if (hc < 0.15 * hmax) continue;
        side = rng.uniform() < 0.75 ? -side : side;
        const Vec2 dir = rotate({-tan.y * side, tan.x * side}, rng.uniform(-0.6, 0.6));
        spur(main.pts[i], dir, W * rng.uniform(0.85, 1.2) * (0.6 + 0.4 * hc / std::max(1e-9, hmax)), 0.93 * hc, 0.42 * W, 0);
      }
    }
  }

  const int blur = int(std::lround(age * 0.1 * W / cell));
  std::vector<Vec2> all;
  for (const auto& l : lines) all.insert(all.end(), l.pts.begin(), l.pts.end());
  ShapeRaster out(box_around(g, all, W + (2 * blur + 2) * cell));
  for (const auto& l : lines) max_ridge(out, g, l, sharp);
  soften(out, blur);
  detail_below_top(out, g, (0.3 + 0.4 * rough) * (1 - 0.5 * age), 0.45 * W, p.look.seed + 7);
  return out;
}

ShapeRaster volcano(const Grid& g, const VolcanoParams& p) {
  const double R = p.radius, H = p.height, cell = cell_of(g), age = p.look.age, rough = p.look.roughness;
  Rng rng(p.look.seed);
  const double rc = p.crater * R;
  const double crater_depth = (0.9 - 0.4 * age) * H * std::min(1.0, 2.5 * p.crater);
  const int blur = int(std::lround(age * 0.06 * R / cell));
  ShapeRaster out(box_around(g, {p.center}, 1.15 * R + (2 * blur + 2) * cell));
  const Box& b = out.box;
  const double expo = 1.5 + 0.6 * age;  // concave flanks, lower and longer with age
  auto cone = [&](double r) { return H * std::pow(std::max(0.0, 1 - r / R), expo); };
  parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
    for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
      for (int x = b.x0; x < b.x0 + b.w; ++x) {
        const double dx = x * g.cell_x - p.center.x, dy = y * g.cell_y - p.center.y;
        const double th = std::atan2(dy, dx);
        // An uneven footprint: the radius wanders with the direction (lava flows ran further).
        const double rr = std::hypot(dx, dy) / (1 + 0.12 * fbm(1.2 * std::cos(th), 1.2 * std::sin(th), 3, 0.5, p.look.seed + 5));
        out.at(x, y) = float(rr < rc ? cone(rc) : cone(rr));
      }
  });
  // Radial ridges between gullies: lines from the rim down the flanks, a little above the cone
  // (more with age: erosion deepens the gullies between them).
  const int n = int(std::lround(12 + 6 * rng.uniform()));
  const double lift = 0.05 + 0.1 * age;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * (k + rng.uniform(-0.35, 0.35)) / n;
    const double r0 = std::max(1.1 * rc, 0.08 * R), r1 = R * rng.uniform(0.75, 1.0);
    RidgeLine l;
    l.pts = branch_path({p.center.x + r0 * std::cos(a), p.center.y + r0 * std::sin(a)}, {std::cos(a), std::sin(a)}, r1 - r0,
                        rng.uniform(-0.3, 0.3), 0.04 + 0.06 * rough, uint32_t(rng.next()));
    for (size_t i = 0; i < l.pts.size(); ++i) {
      const double r = std::hypot(l.pts[i].x - p.center.x, l.pts[i].y - p.center.y);
      l.h.push_back(cone(r) * (1 + lift));
      l.w.push_back(0.1 * R * (0.6 + 0.6 * r / R));
    }
    max_ridge(out, g, l, 0.9);
  }
  soften(out, blur);
  detail_below_top(out, g, (0.25 + 0.35 * rough) * (1 - 0.4 * age), 0.3 * R, p.look.seed + 7);
  // The crater last, a clean bowl under a sharp rim: carved before the detail, its floor got the
  // flanks' full roughness and read as a pitted top rather than a crater.
  if (rc > 0)
    parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
      for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
        for (int x = b.x0; x < b.x0 + b.w; ++x) {
          const double u = std::hypot(x * g.cell_x - p.center.x, y * g.cell_y - p.center.y) / rc;
          if (u >= 1.6) continue;
          const double bowl = u < 1 ? crater_depth * (1 - u * u) : 0.0;
          const double rim = 0.04 * H * std::exp(-8 * (u - 1) * (u - 1));
          float& o = out.at(x, y);
          o = float(std::max(0.0, o - bowl + rim));
        }
    });
  return out;
}

ShapeRaster valley_system(const Grid& g, const ValleyParams& p) {
  const double W = p.width, cell = cell_of(g), rough = p.look.roughness, age = p.look.age;
  Rng rng(p.look.seed);
  const Bands bands = make_bands(p.bands, rng);
  struct Piece {
    std::vector<Vec2> pts;
    std::vector<double> depth, w, bed;
    int parent = -1;  // the piece it joins (-1: none) and where, a vertex of that piece
    size_t at = 0;
  };
  std::vector<Piece> pieces;
  Piece main;
  main.pts = wander_scales(resample(p.stroke, std::max(W / 5, cell)), 1.2 * p.meander * (0.6 + 0.8 * rough), 3 * W, 15 * W,
                           p.look.seed + 1);
  const auto arc = arc_lengths(main.pts);
  for (size_t i = 0; i < main.pts.size(); ++i) {
    main.depth.push_back(p.depth_at(main.pts[i], arc[i], arc.back()));
    // The valley narrows to its head and its mouth and widens and narrows along its course.
    const double end = smoothstep(std::min(arc[i], arc.back() - arc[i]) / std::max(1e-9, W));
    main.w.push_back(W * (0.45 + 0.55 * end) * (1 + 0.2 * fbm(arc[i] / (2.5 * W), 4.3, 2, 0.5, p.look.seed + 12)));
  }
  if (p.depth > 0) {
    // A gorge: the walls (from the floor's edge to the rim) may be as steep as the valley's own or
    // `wall_tan`; the widening that keeps them so is spread over about a width each way (a running
    // maximum, then a running mean), so the walls open before the rise and do not kink.
    const size_t n = main.pts.size();
    const int r = std::max(1, int(std::lround(W / std::max(W / 5, cell))));
    const double wall = std::max(1e-6, (1 - p.floor) * W);
    const double allowed = std::max(p.wall_tan, p.depth / wall);
    std::vector<double> wide(n), grown(n);
    for (size_t i = 0; i < n; ++i) wide[i] = std::clamp(main.depth[i] / (allowed * wall), 1.0, 4.0);
    const auto window = [&](size_t i, auto&& f) {
      for (int k = -r; k <= r; ++k)
        if (int(i) + k >= 0 && int(i) + k < int(n)) f(size_t(int(i) + k));
    };
    for (size_t i = 0; i < n; ++i) window(i, [&](size_t j) { grown[i] = std::max(grown[i], wide[j]); });
    for (size_t i = 0; i < n; ++i) {
      double acc = 0;
      int m = 0;
      window(i, [&](size_t j) { acc += grown[j], ++m; });
      main.w[i] *= acc / m;
    }
  }
  pieces.push_back(main);
  // Side valleys: they join at an acute angle pointing downstream, at uneven spacing, mostly on
  // alternating sides, as deep as the main valley at their mouth and rising to nothing at the tip.
  if (p.branches > 0 && arc.back() > 2 * W) {
    double side = rng.uniform() < 0.5 ? -1 : 1;
    for (double a = W * rng.uniform(0.8, 1.6) / p.branches; a < arc.back() - 0.5 * W; a += W * rng.uniform(1.2, 2.6) / p.branches) {
      size_t i = 0;
      while (i + 2 < main.pts.size() && arc[i + 1] < a) ++i;
      const Vec2 tan = unit({main.pts[i + 1].x - main.pts[i].x, main.pts[i + 1].y - main.pts[i].y});
      side = rng.uniform() < 0.7 ? -side : side;
      const Vec2 dir = rotate({-tan.x, -tan.y}, side * rng.uniform(0.7, 1.3));
      // A side valley keeps most of its depth and width up its course and ends in a rounded head
      // (no tapering spike), and its own tributaries fork off it, so the network is dendritic.
      const auto side_valley = [&](Vec2 mouth, Vec2 d, double len, double d0, double w0, uint32_t seed) {
        Piece s;
        s.pts = branch_path(mouth, d, len, rng.uniform(-0.9, 0.9), 0.12 + 0.12 * rough, seed);
        for (size_t k = 0; k < s.pts.size(); ++k) {
          const double t = double(k) / (s.pts.size() - 1);
          s.depth.push_back(d0 * (1 - std::pow(t, 2.2)) * (0.85 + 0.15 * (1 - t)));
          s.w.push_back(w0 * (0.55 + 0.45 * (1 - t)));
        }
        return s;
      };
      const double len = W * rng.uniform(1.3, 3.0);
      Piece s = side_valley(main.pts[i], dir, len, 0.85 * main.depth[i], main.w[i] * rng.uniform(0.22, 0.38), uint32_t(rng.next()));
      s.parent = 0, s.at = i;
      pieces.push_back(s);
      const int side_index = int(pieces.size()) - 1;
      const int forks = len > 1.8 * W ? 1 + int(rng.uniform() < 0.5) : int(rng.uniform() < 0.5);
      for (int f = 0; f < forks; ++f) {
        const size_t k = std::min(s.pts.size() - 2, size_t(rng.uniform(0.3, 0.75) * double(s.pts.size() - 1)));
        const Vec2 t2 = unit({s.pts[k + 1].x - s.pts[k].x, s.pts[k + 1].y - s.pts[k].y});
        const double turn = (rng.uniform() < 0.5 ? -1 : 1) * rng.uniform(0.5, 1.1);
        Piece fork = side_valley(s.pts[k], rotate(t2, turn), len * rng.uniform(0.3, 0.55), 0.8 * s.depth[k], 0.7 * s.w[k],
                                 uint32_t(rng.next()));
        fork.parent = side_index, fork.at = k;
        pieces.push_back(fork);
      }
    }
  }
  const int blur = int(std::lround(age * 0.08 * W / cell));
  std::vector<Vec2> all;
  for (const auto& pc : pieces) all.insert(all.end(), pc.pts.begin(), pc.pts.end());
  double widest = W;  // a gorge widens the main valley (and its side valleys) beyond W
  for (const auto& pc : pieces) widest = std::max(widest, *std::max_element(pc.w.begin(), pc.w.end()));
  ShapeRaster out(box_around(g, all, widest + (2 * blur + 2) * cell));
  // With the ground, each cell's depth down to its piece's bed (the most of its pieces'): the
  // blur and the relief detail below do not take a cell under it.
  ShapeRaster to_bed(p.ground ? out.box : Box{});
  // A side valley's bed is the ground less its depth, but never below the floor it joins (its
  // depth comes from the main valley's at the mouth, which in a gorge is the ridge's height above
  // the bed, not the side valley's own ground's).
  if (p.ground)
    for (auto& pc : pieces) {
      const double floor = pc.parent >= 0 ? pieces[size_t(pc.parent)].bed[pc.at] : -std::numeric_limits<double>::infinity();
      for (size_t k = 0; k < pc.pts.size(); ++k) pc.bed.push_back(std::max(floor, sample_at(*p.ground, g, pc.pts[k].x, pc.pts[k].y) - pc.depth[k]));
    }
  for (const auto& pc : pieces) {
    const double wmax = *std::max_element(pc.w.begin(), pc.w.end());
    const Nearest n = nearest_on(g, pc.pts, out.box, wmax);
    const auto parc = arc_lengths(pc.pts);
    const Box& b = out.box;
    parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
      for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
        for (int x = b.x0; x < b.x0 + b.w; ++x) {
          const double d = n.dist.at(x, y);
          if (!(d < wmax)) continue;
          const double w = along(pc.w, parc, n.arc.at(x, y));
          if (!(d < w)) continue;
          // With the ground, at most the cell's own height above the bed: nothing goes below
          // the bed, and a cell on ground lower than its vertex is not dug as deep as the vertex.
          // Not more than the vertex's depth either: a side valley climbing a wall stays a groove
          // of its depth instead of cutting a level notch back into the wall.
          double depth = along(pc.depth, parc, n.arc.at(x, y));
          if (p.ground) {
            const double above = std::max(0.0, double(p.ground->at(x, y)) - along(pc.bed, parc, n.arc.at(x, y)));
            to_bed.at(x, y) = std::max(to_bed.at(x, y), float(above));
            depth = std::min(depth, above);
          }
          // The wall's bench edges wander (no ruled stripes); the floor widens and narrows.
          double u = d / w + 0.05 * (0.5 + rough) * fbm(x * g.cell_x / (0.7 * W), y * g.cell_y / (0.7 * W), 3, 0.5, p.look.seed + 9);
          const double f = p.floor * (1 + 0.3 * fbm(n.arc.at(x, y) / (2 * W), 1.7, 2, 0.5, p.look.seed + 11));
          const double t = std::clamp((u - f) / std::max(1e-6, 1 - f), 0.0, 1.0);
          const double e = p.bands > 0 ? bands(t) : 0.5 * (1 - std::cos(M_PI * std::pow(t, 0.8)));
          float& o = out.at(x, y);
          o = std::max(o, float(depth * (1 - e)));
        }
    });
  }
  soften(out, blur);
  // The limit is blurred as the shape is: its steps where the nearest vertex changes (at a bend,
  // along a tapering end) would otherwise cut straight-edged facets into a detailed floor.
  if (p.ground) soften(to_bed, std::max(blur, int(std::lround(0.05 * W / cell))));
  ShapeRaster detail = out;
  add_relief_detail(detail, g, (0.15 + 0.35 * rough) * (1 - 0.5 * age), 0.4 * W, p.look.seed + 7,
                    p.depth > 0 ? p.depth : std::numeric_limits<double>::infinity());
  out = std::move(detail);
  if (p.ground)
    for (size_t i = 0; i < out.v.size(); ++i)
      if (to_bed.v[i] > 0) out.v[i] = std::min(out.v[i], to_bed.v[i]);
  if (p.to_bed) *p.to_bed = std::move(to_bed);
  return out;
}

ShapeRaster escarpment(const Grid& g, const EscarpmentParams& p) {
  const double D = p.drop, cell = cell_of(g), rough = p.look.roughness, age = p.look.age;
  Rng rng(p.look.seed);
  const Bands bands = make_bands(p.bands, rng);
  const double face = std::max(2 * cell, (0.3 + 0.3 * age) * D);
  const double apron = std::max(2 * cell, p.talus * D * 2.2);
  const auto line = wander_scales(resample(p.stroke, std::max(cell, D / 2)), 0.2 + 0.2 * rough, 3 * D, 40 * D, p.look.seed + 1);
  const auto arc = arc_lengths(line);
  const double L = arc.back(), taper = std::min(2 * D, L / 4);
  // Chutes: notches cut back into the plateau edge at uneven spacing.
  struct Chute {
    double at, half, cut;
  };
  std::vector<Chute> chutes;
  // Their sizes are heavy-tailed, as gullies on a real scarp: many small notches, a few deep
  // re-entrants cut far back into the plateau, with the spacing growing with the size.
  for (double a = D * rng.uniform(0.3, 1.0); a < L;) {
    const double size = std::pow(rng.uniform(0.05, 1.0), 2.5);
    chutes.push_back({a, D * (0.1 + 0.5 * size) * rng.uniform(0.8, 1.2), face * (0.5 + 3.5 * size)});
    a += D * (0.4 + 2.0 * rng.uniform()) * (0.7 + 1.5 * size);
  }
  const double reach = std::max(p.back, face + apron) + face * 2.5;
  const int blur = int(std::lround(age * 0.08 * D / cell));
  ShapeRaster out(box_around(g, line, reach + (2 * blur + 2) * cell));
  const Nearest n = nearest_on(g, line, out.box, reach);
  ShapeRaster rock(out.box);  // where the detail goes: the face and the apron, barely the plateau
  const double plateau_side = p.left ? -1.0 : 1.0;  // Nearest's side is +1 on the right (map view)
  const Box& b = out.box;
  parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
    for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
      for (int x = b.x0; x < b.x0 + b.w; ++x) {
        const double d = n.dist.at(x, y);
        if (!(d < reach)) continue;
        const double s = n.arc.at(x, y);
        double notch = 0;
        const double sd0 = n.side.at(x, y) * plateau_side * d;  // > 0 on the plateau
        for (const auto& c : chutes) {
          // A V-shaped groove cut back into the edge, fading out on the plateau behind it.
          const double v = c.cut * std::pow(std::max(0.0, 1 - std::abs(s - c.at) / c.half), 1.5);
          notch = std::max(notch, v * std::clamp(1 - sd0 / (2 * c.cut), 0.0, 1.0));
        }
        const double sd = sd0 - notch;
        double h;
        if (sd >= 0) {
          // The plateau, then its back slope, whose top edge wanders along the stroke (a ruled
          // edge parallel to the brink read as a crease behind the cliff).
          const double flat = 0.35 * p.back * (1 + 0.8 * fbm(s / (1.5 * D), 0.37, 3, 0.5, p.look.seed + 5));
          h = D * (1 - smoothstep((sd - flat) / std::max(p.back - flat, face)));
        }
        else if (sd > -face) h = D * (p.talus + (1 - p.talus) * bands(1 + sd / face));  // the face
        else h = D * p.talus * std::pow(std::max(0.0, 1 - (-sd - face) / apron), 2);   // the apron
        const double end = taper > 0 ? smoothstep(std::min(s, L - s) / taper) : 1.0;
        out.at(x, y) = float(h * end);
        // Detail on the face (none at its brink: no teeth above the plateau) and the apron.
        const double tf = 1 + sd / face;
        const double wr = sd >= 0 ? 0.08 : sd > -face ? 0.08 + 0.92 * 4 * tf * (1 - tf) : 0.5;
        rock.at(x, y) = float(end * wr * (h > 0 ? 1.0 : 0.0));
      }
  });
  soften(out, blur);
  // Detail in metres of the drop, on the rock: a plateau keeps a gentle surface.
  const double amp = (0.08 + 0.2 * rough) * (1 - 0.5 * age) * D;
  const double wl = 0.6 * D, cellm = cell_of(g);
  const int oct = octaves_down_to_cells(wl, cellm);
  parallel_for(size_t(b.h), 0, [&](size_t r0, size_t r1) {
    for (int y = b.y0 + int(r0); y < b.y0 + int(r1); ++y)
      for (int x = b.x0; x < b.x0 + b.w; ++x)
        if (rock.at(x, y) > 0)
          out.at(x, y) += float(amp * rock.at(x, y) * ridged(x * g.cell_x / wl, y * g.cell_y / wl, oct, 0.62, p.look.seed + 7));
  });
  return out;
}

}  // namespace terracl::edit
