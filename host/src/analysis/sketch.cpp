// SPDX-License-Identifier: Apache-2.0
// Sketch extraction as in the terrain-GAN literature (Guerin et al. 2017; "Interactive adversarial
// terrain erosion", section on sketches): rivers are cells whose D8 accumulation exceeds a
// threshold, ridges the same on the inverted terrain, peaks and basins come from max/min filters
// with a relief threshold. The D8 network above a threshold is a tree of one-cell-wide paths, so it
// is already the skeleton the paper obtains by thinning a thresholded image; we trace it into
// polylines (split at confluences), re-trace each segment as a sub-cell streamline (the continuous
// D-infinity direction) where it can be, smooth them along their length to remove what is left of
// D8's 0/45-deg staircase, and draw those.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <terracl/error.hpp>

#include "analysis/grid.hpp"

namespace terracl::analysis {

using json = nlohmann::json;
using namespace detail;

namespace {

Heightfield gaussian_blur(const Heightfield& h, double sigma) {
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<double> k(2 * r + 1);
  for (int i = -r; i <= r; ++i) k[i + r] = std::exp(-0.5 * i * i / (sigma * sigma));
  Heightfield tmp = h, out = h;
  auto pass = [&](const Heightfield& src, Heightfield& dst, int dx, int dy) {
    for (int y = 0; y < src.height; ++y)
      for (int x = 0; x < src.width; ++x) {
        if (std::isnan(src.at(x, y))) continue;
        double s = 0, ws = 0;
        for (int i = -r; i <= r; ++i) {
          const int xx = x + i * dx, yy = y + i * dy;
          if (xx < 0 || yy < 0 || xx >= src.width || yy >= src.height) continue;
          const float v = src.at(xx, yy);
          if (std::isnan(v)) continue;
          s += k[i + r] * v;
          ws += k[i + r];
        }
        dst.at(x, y) = float(s / ws);
      }
  };
  pass(h, tmp, 1, 0);
  pass(tmp, out, 0, 1);
  return out;
}

/// Douglas-Peucker on the (x, y) coordinates.
void simplify(const std::vector<Sketch::Point>& in, double tol, std::vector<Sketch::Point>& out) {
  if (in.size() <= 2 || tol <= 0) {
    out = in;
    return;
  }
  std::vector<uint8_t> keep(in.size(), 0);
  keep.front() = keep.back() = 1;
  std::vector<std::pair<size_t, size_t>> todo{{0, in.size() - 1}};
  while (!todo.empty()) {
    auto [a, b] = todo.back();
    todo.pop_back();
    const double ax = in[a].x, ay = in[a].y, dx = in[b].x - ax, dy = in[b].y - ay;
    const double len = std::hypot(dx, dy);
    double worst = -1;
    size_t wi = a;
    for (size_t i = a + 1; i < b; ++i) {
      const double d =
          len > 0 ? std::abs(dx * (in[i].y - ay) - dy * (in[i].x - ax)) / len : std::hypot(in[i].x - ax, in[i].y - ay);
      if (d > worst) worst = d, wi = i;
    }
    if (worst > tol) {
      keep[wi] = 1;
      todo.push_back({a, wi});
      todo.push_back({wi, b});
    }
  }
  out.clear();
  for (size_t i = 0; i < in.size(); ++i)
    if (keep[i]) out.push_back(in[i]);
}

/// Gaussian smoothing of the (x, y) of a D8 path along its vertices, sigma in vertices. A D8 path
/// only knows 8 directions, so a ridge or valley at 20 deg comes out as long runs at 0 deg broken by
/// 45-deg steps (the staircase of the sketch pictures); averaging over a few cells recovers the
/// direction in between. The window is symmetric and shrinks towards the ends, which stay where
/// they are, so lines still meet at their confluences; a straight run keeps its coordinates exactly
/// (the average is taken of offsets from the vertex itself).
void smooth_path(std::vector<Sketch::Point>& pts, double sigma) {
  const int n = int(pts.size());
  if (sigma <= 0 || n < 3) return;
  const int r_max = std::max(1, int(std::ceil(2.5 * sigma)));
  std::vector<double> k(r_max + 1);
  for (int i = 0; i <= r_max; ++i) k[i] = std::exp(-0.5 * i * i / (sigma * sigma));
  std::vector<Sketch::Point> out = pts;
  for (int i = 1; i + 1 < n; ++i) {
    const int r = std::min({r_max, i, n - 1 - i});
    double sx = 0, sy = 0, ws = k[0];
    for (int j = 1; j <= r; ++j) {
      sx += k[j] * ((pts[i - j].x - pts[i].x) + (pts[i + j].x - pts[i].x));
      sy += k[j] * ((pts[i - j].y - pts[i].y) + (pts[i + j].y - pts[i].y));
      ws += 2 * k[j];
    }
    out[i].x = pts[i].x + sx / ws;
    out[i].y = pts[i].y + sy / ws;
  }
  pts = std::move(out);
}

/// Moves the inner vertices of a traced path across it to the sub-cell position of the valley
/// floor (the minimum of `surface` across the path; ridges are traced on the inverted terrain): a
/// least-squares parabola through 5 bilinear samples at -2..2 cells along the path's normal, its
/// vertex clamped to half a cell. A D8 run at 0 deg along a crest that really runs at 20 deg drifts
/// across its cells, so these offsets grow along the run and restore the true direction, which
/// smoothing alone cannot do for runs longer than its window.
void localise_subcell(std::vector<Sketch::Point>& pts, const Heightfield& surface) {
  const int n = int(pts.size());
  if (n < 3) return;
  auto sample = [&](double x, double y) {
    x = std::clamp(x, 0.0, double(surface.width - 1));
    y = std::clamp(y, 0.0, double(surface.height - 1));
    const int x0 = std::clamp(int(x), 0, std::max(0, surface.width - 2));
    const int y0 = std::clamp(int(y), 0, std::max(0, surface.height - 2));
    const int x1 = std::min(x0 + 1, surface.width - 1), y1 = std::min(y0 + 1, surface.height - 1);
    const double tx = x - x0, ty = y - y0;
    const double a = surface.at(x0, y0), b = surface.at(x1, y0), c = surface.at(x0, y1), d = surface.at(x1, y1);
    return (1 - ty) * ((1 - tx) * a + tx * b) + ty * ((1 - tx) * c + tx * d);
  };
  std::vector<Sketch::Point> out = pts;
  std::vector<uint8_t> placed(n, 0);
  placed[0] = placed[n - 1] = 1;
  for (int i = 1; i + 1 < n; ++i) {
    const int a = std::max(0, i - 2), b = std::min(n - 1, i + 2);
    double tx = pts[b].x - pts[a].x, ty = pts[b].y - pts[a].y;
    const double len = std::hypot(tx, ty);
    if (len <= 0) continue;
    tx /= len, ty /= len;
    const double nx = -ty, ny = tx;
    double f[5];
    bool ok = true;
    for (int k = -2; k <= 2; ++k) {
      f[k + 2] = sample(pts[i].x + k * nx, pts[i].y + k * ny);
      ok = ok && std::isfinite(f[k + 2]);
    }
    if (!ok) continue;
    const double lin = (-2 * f[0] - f[1] + f[3] + 2 * f[4]) / 10.0;
    const double quad = (2 * f[0] - f[1] - 2 * f[2] - f[3] + 2 * f[4]) / 14.0;
    if (!(quad > 1e-9)) continue;  // not a trough across the path: leave the vertex
    const double off = std::clamp(-lin / (2 * quad), -0.5, 0.5);
    out[i].x = std::clamp(pts[i].x + off * nx, 0.0, double(surface.width - 1));
    out[i].y = std::clamp(pts[i].y + off * ny, 0.0, double(surface.height - 1));
    placed[i] = 1;
  }
  // Where there is no trough across the path (a flat, e.g. a filled depression the D8 routing
  // crosses in straight runs), the path is straightened between the placed vertices around it.
  for (int i = 1; i + 1 < n; ++i) {
    if (placed[i]) continue;
    int j = i;
    while (!placed[j]) ++j;
    const Sketch::Point p0 = out[i - 1], p1 = out[j];
    for (int k = i; k < j; ++k) {
      const double t = double(k - (i - 1)) / double(j - (i - 1));
      out[k].x = p0.x + t * (p1.x - p0.x);
      out[k].y = p0.y + t * (p1.y - p0.y);
    }
    i = j;
  }
  pts = std::move(out);
}

/// Re-traces a D8 segment (first cell to last cell) as a sub-cell streamline of `surface`: steps of
/// half a cell down the gradient of the bilinearly interpolated central-difference slope field, the
/// continuous form of Tarboton's (1997) D-infinity direction. On a planar slope at 17 deg the D8 path
/// is a 0/45-deg staircase with no trough across it to localise; the streamline runs at 17 deg. The
/// D8 path stays the topology: the streamline starts on its first cell, ends on its last (the
/// confluence) and must stay within 2 cells of it, else (flats, a streamline captured by another
/// valley) false is returned and the caller keeps the D8 geometry.
bool trace_streamline(const std::vector<Sketch::Point>& path, const Heightfield& surface, const Heightfield& original,
                      std::vector<Sketch::Point>& out) {
  const int n = int(path.size()), w = surface.width, h = surface.height;
  if (n < 3 || w < 2 || h < 2) return false;
  auto z = [&](const Heightfield& f, int x, int y) {
    return double(f.at(std::clamp(x, 0, w - 1), std::clamp(y, 0, h - 1)));
  };
  // Central differences (one-sided at the border) at a cell, in surface units per cell.
  auto grad = [&](int x, int y, double& gx, double& gy) {
    const int xl = std::max(x - 1, 0), xr = std::min(x + 1, w - 1), yt = std::max(y - 1, 0), yb = std::min(y + 1, h - 1);
    gx = (z(surface, xr, y) - z(surface, xl, y)) / std::max(1, xr - xl);
    gy = (z(surface, x, yb) - z(surface, x, yt)) / std::max(1, yb - yt);
  };
  auto bilinear = [&](double px, double py, auto&& f) {
    const int x0 = std::clamp(int(std::floor(px)), 0, w - 2), y0 = std::clamp(int(std::floor(py)), 0, h - 2);
    const double tx = std::clamp(px - x0, 0.0, 1.0), ty = std::clamp(py - y0, 0.0, 1.0);
    return (1 - ty) * ((1 - tx) * f(x0, y0) + tx * f(x0 + 1, y0)) + ty * ((1 - tx) * f(x0, y0 + 1) + tx * f(x0 + 1, y0 + 1));
  };
  out.clear();
  double px = path[0].x, py = path[0].y;
  out.push_back(path[0]);
  const Sketch::Point end = path.back();
  int near = 0;  // the D8 vertex the streamline is at, advancing only
  for (int step = 0; step < 4 * n + 16; ++step) {
    if (std::hypot(px - end.x, py - end.y) <= 0.75) {
      out.push_back(end);
      return true;
    }
    const double gx = bilinear(px, py, [&](int x, int y) { double a, b; grad(x, y, a, b); return a; });
    const double gy = bilinear(px, py, [&](int x, int y) { double a, b; grad(x, y, a, b); return b; });
    const double g = std::hypot(gx, gy);
    if (!(g > 1e-9)) return false;  // a flat: no direction
    px = std::clamp(px - 0.5 * gx / g, 0.0, double(w - 1));
    py = std::clamp(py - 0.5 * gy / g, 0.0, double(h - 1));
    double best = INFINITY;
    int bi = near;
    for (int j = near; j < std::min(n, near + 4); ++j) {
      const double d = std::hypot(px - path[j].x, py - path[j].y);
      if (d < best) best = d, bi = j;
    }
    if (best > 2.0) return false;  // left the D8 segment's corridor
    near = bi;
    out.push_back({px, py, bilinear(px, py, [&](int x, int y) { return z(original, x, y); })});
  }
  return false;
}

/// Draws a polyline one pixel wide (steps of at most half a pixel, nearest pixel).
void draw_line(const std::vector<Sketch::Point>& pts, int w, int h, std::vector<uint8_t>& mask) {
  auto plot = [&](double x, double y) {
    const long xi = std::lround(x), yi = std::lround(y);
    if (xi >= 0 && yi >= 0 && xi < w && yi < h) mask[size_t(yi) * w + size_t(xi)] = 1;
  };
  if (!pts.empty()) plot(pts[0].x, pts[0].y);
  for (size_t k = 1; k < pts.size(); ++k) {
    const double dx = pts[k].x - pts[k - 1].x, dy = pts[k].y - pts[k - 1].y;
    const int steps = std::max(1, int(std::ceil(2 * std::max(std::abs(dx), std::abs(dy)))));
    for (int s = 1; s <= steps; ++s) plot(pts[k - 1].x + dx * s / steps, pts[k - 1].y + dy * s / steps);
  }
}

/// Traces the D8 network above `threshold` cells into polylines split at confluences, smoothed
/// along their length (`line_sigma` cells) and simplified; draws the smoothed lines into `mask`.
std::vector<Sketch::Line> trace_network(const Heightfield& surface, const Heightfield& original, double threshold,
                                        double simplify_tol, double line_sigma, std::vector<uint8_t>& mask) {
  const D8Result d8 = d8_flow(surface);
  const size_t n = surface.size();
  const int w = surface.width;
  mask.assign(n, 0);
  for (size_t i = 0; i < n; ++i)
    if (d8.dir[i] != kNoFlow && d8.cells[i] >= threshold) mask[i] = 1;
  std::vector<uint8_t> donors(n, 0);
  auto receiver = [&](size_t i) -> ptrdiff_t {
    const uint8_t d = d8.dir[i];
    if (d >= 8) return -1;
    return ptrdiff_t(i) + ptrdiff_t(kDy[d]) * w + kDx[d];
  };
  for (size_t i = 0; i < n; ++i)
    if (mask[i]) {
      const ptrdiff_t j = receiver(i);
      if (j >= 0) donors[size_t(j)]++;
    }
  // Strahler order of every network cell, heads first (Kahn's order over the network's donors): a
  // cell takes the largest order flowing in, plus one where two or more inflows share it.
  std::vector<uint8_t> order(n, 0), max_in(n, 0), n_max(n, 0), pending = donors;
  std::vector<size_t> ready;
  for (size_t i = 0; i < n; ++i)
    if (mask[i] && donors[i] == 0) order[i] = 1, ready.push_back(i);
  while (!ready.empty()) {
    const size_t i = ready.back();
    ready.pop_back();
    const ptrdiff_t r = receiver(i);
    if (r < 0 || !mask[size_t(r)]) continue;
    const size_t j = size_t(r);
    if (order[i] > max_in[j]) max_in[j] = order[i], n_max[j] = 1;
    else if (order[i] == max_in[j]) ++n_max[j];
    if (--pending[j] == 0) {
      order[j] = uint8_t(std::min(255, max_in[j] + (n_max[j] >= 2 ? 1 : 0)));
      ready.push_back(j);
    }
  }
  std::vector<Sketch::Line> lines;
  std::vector<std::vector<Sketch::Point>> smoothed;
  std::vector<Sketch::Point> pts;
  for (size_t i = 0; i < n; ++i) {
    // A segment starts at a channel head (no network donor) or just below a confluence.
    if (!mask[i] || donors[i] == 1) continue;
    pts.clear();
    size_t c = i;
    while (true) {
      pts.push_back({double(c % w), double(c / w), double(original.z[c])});
      const ptrdiff_t j = receiver(c);
      if (j < 0) break;
      c = size_t(j);
      if (donors[c] != 1) {  // confluence: end here, it starts its own segment
        pts.push_back({double(c % w), double(c / w), double(original.z[c])});
        break;
      }
    }
    if (pts.size() < 2) continue;
    Sketch::Line line;
    const size_t last = size_t(pts.back().y) * w + size_t(pts.back().x);
    std::vector<Sketch::Point> stream;
    if (line_sigma > 0 && trace_streamline(pts, surface, original, stream)) {
      pts = std::move(stream);
      smooth_path(pts, 2 * line_sigma);  // vertices are half a cell apart
    } else {
      if (line_sigma > 0) localise_subcell(pts, surface);
      smooth_path(pts, line_sigma);
    }
    simplify(pts, simplify_tol, line.points);
    line.drainage_area_m2 = d8.area_m2(last);
    line.strahler = order[i];  // a segment's cells share its start's order (no confluence inside)
    lines.push_back(std::move(line));
    smoothed.push_back(pts);
  }
  // The picture shows the smoothed lines, not the D8 cells (the same staircase otherwise).
  mask.assign(n, 0);
  for (const auto& p : smoothed) draw_line(p, w, surface.height, mask);
  return lines;
}

/// Moving max (sign +1) or min (sign -1) over a window x window square, ignoring nodata.
std::vector<float> extremum_filter(const Heightfield& h, int window, float sign) {
  const int r = window / 2;
  std::vector<float> tmp(h.size(), NAN), out(h.size(), NAN);
  auto better = [&](float a, float b) { return std::isnan(b) || (!std::isnan(a) && sign * a > sign * b) ? a : b; };
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      float m = NAN;
      for (int i = std::max(0, x - r); i <= std::min(h.width - 1, x + r); ++i) m = better(h.at(i, y), m);
      tmp[size_t(y) * h.width + x] = m;
    }
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      float m = NAN;
      for (int j = std::max(0, y - r); j <= std::min(h.height - 1, y + r); ++j)
        m = better(tmp[size_t(j) * h.width + x], m);
      out[size_t(y) * h.width + x] = m;
    }
  return out;
}

std::vector<Sketch::Extremum> find_extrema(const Heightfield& surface, const Heightfield& original,
                                           const std::vector<float>& fmax, const std::vector<float>& fmin, bool peaks,
                                           int window, double prominence) {
  struct Cand {
    float z;
    size_t i;
  };
  std::vector<Cand> cand;
  const int w = surface.width;
  for (int y = 1; y < surface.height - 1; ++y)
    for (int x = 1; x < w - 1; ++x) {
      const size_t i = size_t(y) * w + x;
      const float z = surface.z[i];
      if (std::isnan(z)) continue;
      if (z != (peaks ? fmax[i] : fmin[i])) continue;
      if (double(fmax[i]) - double(fmin[i]) < prominence) continue;
      cand.push_back({z, i});
    }
  // Highest peaks (lowest basins) first; index order breaks ties; suppress others in the window.
  std::sort(cand.begin(), cand.end(), [&](const Cand& a, const Cand& b) {
    if (a.z != b.z) return peaks ? a.z > b.z : a.z < b.z;
    return a.i < b.i;
  });
  std::vector<Sketch::Extremum> out;
  const int r = window / 2;
  for (const Cand& c : cand) {
    const int x = int(c.i % w), y = int(c.i / w);
    bool near = false;
    for (const auto& e : out) near = near || (std::abs(int(e.p.x) - x) <= r && std::abs(int(e.p.y) - y) <= r);
    if (near) continue;
    out.push_back({{double(x), double(y), double(original.z[c.i])}, double(fmax[c.i]) - double(fmin[c.i])});
  }
  return out;
}

}  // namespace

Sketch extract_sketch(const Heightfield& h, const SketchOptions& opt, const Progress& progress) {
  const char* stage = "sketch";
  require_indexable(h, stage);
  if (opt.window < 3) fail(stage, "window must be at least 3 cells, got {}", opt.window);
  if (opt.river_fraction <= 0 || opt.ridge_fraction <= 0 || opt.river_fraction > 1 || opt.ridge_fraction > 1)
    fail(stage, "river/ridge fractions must be in (0, 1]");
  if (!(opt.line_smooth_cells >= 0 && opt.line_smooth_cells <= 100))
    fail(stage, "line_smooth must be in [0, 100] cells, got {}", opt.line_smooth_cells);
  const HeightStats st = compute_stats(h);
  if (st.valid == 0) fail(stage, "the heightfield has no valid cell");
  Heightfield surface = opt.smooth_cells > 0 ? gaussian_blur(h, opt.smooth_cells) : h;
  Sketch s;
  s.width = h.width;
  s.height = h.height;
  const double valid = double(st.valid);
  std::vector<uint8_t> river_mask, ridge_mask;
  s.rivers = trace_network(surface, h, std::max<double>(opt.min_cells, opt.river_fraction * valid), opt.simplify_cells,
                           opt.line_smooth_cells, river_mask);
  report_progress(progress, stage, 0.4, "rivers");
  Heightfield inverted = surface;
  for (float& v : inverted.z) v = -v;
  s.ridges = trace_network(inverted, h, std::max<double>(opt.min_cells, opt.ridge_fraction * valid), opt.simplify_cells,
                           opt.line_smooth_cells, ridge_mask);
  report_progress(progress, stage, 0.8, "ridges");
  const int window = opt.window | 1;
  const std::vector<float> fmax = extremum_filter(surface, window, 1.f), fmin = extremum_filter(surface, window, -1.f);
  const double prom = opt.prominence_m >= 0 ? opt.prominence_m : 0.1 * (st.max - st.min);
  s.peaks = find_extrema(surface, h, fmax, fmin, true, window, std::max(prom, 1e-9));
  s.basins = find_extrema(surface, h, fmax, fmin, false, window, std::max(prom, 1e-9));

  const size_t n = h.size();
  s.rgb.assign(3 * n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (ridge_mask[i]) s.rgb[3 * i + 0] = 255;
    if (river_mask[i]) s.rgb[3 * i + 1] = 255;
  }
  const double range = st.max > st.min ? st.max - st.min : 1.0;
  const int pr = std::max(0, opt.patch / 2);
  auto stamp = [&](const Sketch::Extremum& e) {
    const uint8_t v = uint8_t(std::clamp(1.0 + 254.0 * (e.p.z - st.min) / range, 1.0, 255.0));
    for (int y = int(e.p.y) - pr; y <= int(e.p.y) + pr; ++y)
      for (int x = int(e.p.x) - pr; x <= int(e.p.x) + pr; ++x)
        if (x >= 0 && y >= 0 && x < h.width && y < h.height) s.rgb[3 * (size_t(y) * h.width + x) + 2] = v;
  };
  for (const auto& e : s.basins) stamp(e);
  for (const auto& e : s.peaks) stamp(e);  // peaks drawn last: they win where squares overlap
  report_progress(progress, stage, 1.0, "peaks and basins");
  return s;
}

json sketch_to_json(const Sketch& s, const Heightfield& h) {
  auto line_json = [](const std::vector<Sketch::Line>& lines) {
    json a = json::array();
    for (const auto& l : lines) {
      json pts = json::array();
      for (const auto& p : l.points) pts.push_back({p.x, p.y, p.z});
      a.push_back({{"points", pts}, {"drainage_area_m2", l.drainage_area_m2}, {"strahler", l.strahler}});
    }
    return a;
  };
  auto point_json = [](const std::vector<Sketch::Extremum>& v) {
    json a = json::array();
    for (const auto& e : v) a.push_back({{"x", e.p.x}, {"y", e.p.y}, {"z", e.p.z}, {"relief_m", e.relief_m}});
    return a;
  };
  json j;
  j["format"] = "terracl-sketch";
  j["version"] = 1;
  j["width"] = s.width;
  j["height"] = s.height;
  j["cell_x_m"] = h.georef.cell_x;
  j["cell_y_m"] = h.georef.cell_y;
  j["coordinates"] = "pixel: x = column, y = row of the cell centre (row 0 north); z = elevation in m";
  if (h.georef.has_geotransform) j["geotransform"] = h.georef.geotransform;
  if (!h.georef.crs_wkt.empty()) j["crs_wkt"] = h.georef.crs_wkt;
  j["rivers"] = line_json(s.rivers);
  j["ridges"] = line_json(s.ridges);
  j["peaks"] = point_json(s.peaks);
  j["basins"] = point_json(s.basins);
  return j;
}

}  // namespace terracl::analysis
