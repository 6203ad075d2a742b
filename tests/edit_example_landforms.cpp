// Geometry of the gallery's strokes and the cliff and mountain-range checks (edit_example_checks.hpp).
#include "edit_example_checks.hpp"

#include "test_helpers.hpp"

#include <terracl/analysis.hpp>
#include <terracl/edit.hpp>
#include <terracl/io.hpp>
#include <terracl/tensor.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <set>

namespace terracl::test::examples {

// Height at (x, y) metres from the centre of cell (0, 0), bilinear (clamped to the grid).
double at_m(const Heightfield& h, double cell, double x, double y) {
  const double fx = std::clamp(x / cell, 0.0, h.width - 1.001), fy = std::clamp(y / cell, 0.0, h.height - 1.001);
  const int x0 = int(fx), y0 = int(fy);
  const double tx = fx - x0, ty = fy - y0;
  return (1 - ty) * ((1 - tx) * h.at(x0, y0) + tx * h.at(x0 + 1, y0)) +
         ty * ((1 - tx) * h.at(x0, y0 + 1) + tx * h.at(x0 + 1, y0 + 1));
}

// The middle vertex of a stroke with an odd number of points (a smoothed stroke passes through it),
// else the middle of the middle segment; the normal from the neighbouring points.
Stroke middle_of(const nlohmann::json& pts) {
  const size_t n = pts.size();
  const auto& a = pts[n % 2 ? n / 2 - 1 : n / 2 - 1];
  const auto& b = pts[n % 2 ? n / 2 + 1 : n / 2];
  const double ax = a[0], ay = a[1], bx = b[0], by = b[1];
  double mx = 0.5 * (ax + bx), my = 0.5 * (ay + by);
  if (n % 2) mx = pts[n / 2][0], my = pts[n / 2][1];
  const double l = std::hypot(bx - ax, by - ay);
  return {mx, my, -(by - ay) / l, (bx - ax) / l};
}

// The canyon's side canyons where they cut the rims: stations every 20 m along each smoothed cliff
// rim (the cliffs' points through catmull_rom), 200 m or more inside the map, where the terrain lies
// >= 250 m below the cliff's `elevation`; runs of such stations closer than 60 m are one cut.
std::vector<RimCut> canyon_cuts(const nlohmann::json& script, const Heightfield& h, double cell) {
  const double extent = (h.width - 1) * cell;
  std::vector<RimCut> cuts;
  int rim = 0;
  for (const auto& o : script.at("operations")) {
    if (o.at("op") != "cliff") continue;
    std::vector<Vec2> ctrl;
    for (const auto& q : o.at("points")) ctrl.push_back({double(q[0]), double(q[1])});
    const double top = o.at("elevation");
    std::vector<Vec2> line;
    Vec2 last{-1e30, -1e30};
    for (const auto& v : catmull_rom(ctrl, 5.0))
      if (std::hypot(v.x - last.x, v.y - last.y) >= 20) line.push_back(v), last = v;
    bool open = false;
    double since = 1e30;
    for (const auto& v : line) {
      since += 20;
      if (v.x < 200 || v.y < 200 || v.x > extent - 200 || v.y > extent - 200) continue;
      const double z = at_m(h, cell, v.x, v.y);
      if (z < top - 250) {
        if (!open || since > 60) cuts.push_back({}), cuts.back().rim = rim;
        cuts.back().stations.push_back(v), cuts.back().lowest = std::min(cuts.back().lowest, z);
        open = true, since = 0;
      }
    }
    ++rim;
  }
  return cuts;
}

// Inside a polygon (even-odd rule).
bool in_polygon(const nlohmann::json& poly, double x, double y) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const double xi = poly[i][0], yi = poly[i][1], xj = poly[j][0], yj = poly[j][1];
    if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) in = !in;
  }
  return in;
}

// Shape facts of the gallery, so that a regression towards "1-pixel scratches", "a dark
// line without scree" or "a crest that is only a shading edge" fails. `cell` is the cell size of
// the run (twice the script's: the suite runs the 1025^2 examples at 513^2).

// The cliff example faces west (into the light: a lit face), its plateau east. Its checks are
// written for a plateau north of a west-east cliff: this turns the terrain and the script a
// quarter turn (new (X, Y) -> (Y, extent - X)) and checks that.
bool check_turned_cliff(const nlohmann::json& script, const Heightfield& h, double cell) {
  const double extent = (h.width - 1) * cell;
  for (const auto& op : script.at("operations")) {
    if (op.at("op") != "cliff") continue;
    const auto& pts = op.at("points");
    const double dx = double(pts.back()[0]) - double(pts.front()[0]), dy = double(pts.back()[1]) - double(pts.front()[1]);
    if (std::abs(dy) <= std::abs(dx)) return false;
  }
  Heightfield t = h;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) t.at(x, y) = h.at(h.width - 1 - y, x);
  nlohmann::json s = script;
  auto turn = [&](nlohmann::json& q) {
    const double X = q[0], Y = q[1];
    q[0] = Y, q[1] = extent - X;
  };
  for (auto& op : s.at("operations")) {
    if (op.contains("points"))
      for (auto& q : op["points"]) turn(q);
    if (op.contains("polygon"))
      for (auto& q : op["polygon"]) turn(q);
  }
  check_shapes("cliff", s, t, cell);
  return true;
}

// The cliff band reads as natural rock (figure 14), on the turned terrain (plateau north):
// gullies at irregular spacing along the brink, a plateau with relief, a brink that wanders. Each
// bound fails on the former example (ten evenly spaced identical gullies, a slab frozen flat after
// 3 m of noise, a 4-point rim whose only bend is one bow).
void check_cliff_band(const nlohmann::json& op, const Heightfield& h, double cell) {
  const double extent = (h.width - 1) * cell;
  std::vector<Vec2> ctrl;
  for (const auto& q : op.at("points")) ctrl.push_back({double(q[0]), double(q[1])});
  const double r = 0.5 * double(op.at("width")), face_w = double(op.value("face", 0.3)) * r;
  auto inside = [&](double x, double y, double m) { return x >= m && y >= m && x <= extent - m && y <= extent - m; };
  auto z = [&](double x, double y) { return at_m(h, cell, x, y); };
  // Stations every 5 m along the smoothed rim, with the normal pointing down the face.
  const auto rim = catmull_rom(ctrl, 5.0);
  struct Station {
    double x, y, nx, ny, s;
  };
  std::vector<Station> st;
  double s = 0;
  for (size_t i = 1; i + 1 < rim.size(); ++i) {
    s += std::hypot(rim[i].x - rim[i - 1].x, rim[i].y - rim[i - 1].y);
    const double tx = rim[i + 1].x - rim[i - 1].x, ty = rim[i + 1].y - rim[i - 1].y, l = std::hypot(tx, ty);
    if (l > 0 && inside(rim[i].x, rim[i].y, 60)) st.push_back({rim[i].x, rim[i].y, -ty / l, tx / l, s});
  }
  ASSERT_GT(st.size(), 100u);
  const Station& mid = st[st.size() / 2];
  if (z(mid.x + 60 * mid.nx, mid.y + 60 * mid.ny) > z(mid.x - 60 * mid.nx, mid.y - 60 * mid.ny))
    for (auto& q : st) q.nx = -q.nx, q.ny = -q.ny;

  // Gullies: hollows across the face at half its width, below the running median (+-150 m) by more
  // than 8 m; runs closer than 30 m are one gully, its centre the run's lowest point.
  std::vector<double> zf;
  for (const auto& q : st) zf.push_back(z(q.x + 0.5 * face_w * q.nx, q.y + 0.5 * face_w * q.ny));
  std::vector<double> centres;
  double run_lo = 1e30, run_s = -1, last_s = -1e30;
  for (size_t i = 0; i < st.size(); ++i) {
    size_t a = i, b = i;
    while (a > 0 && st[i].s - st[a - 1].s <= 150) --a;
    while (b + 1 < st.size() && st[b + 1].s - st[i].s <= 150) ++b;
    std::vector<double> w(zf.begin() + a, zf.begin() + b + 1);
    std::nth_element(w.begin(), w.begin() + w.size() / 2, w.end());
    const double dev = zf[i] - w[w.size() / 2];
    if (dev < -8) {
      if (st[i].s - last_s > 30 && run_s >= 0) centres.push_back(run_s), run_lo = 1e30;
      if (dev < run_lo) run_lo = dev, run_s = st[i].s;
      last_s = st[i].s;
    }
  }
  if (run_s >= 0) centres.push_back(run_s);
  ASSERT_GE(centres.size(), 6u) << "the cliff band has gullies across its face";
  std::vector<double> gap;
  for (size_t i = 1; i < centres.size(); ++i) gap.push_back(centres[i] - centres[i - 1]);
  double mean = 0, var = 0;
  for (double g : gap) mean += g / gap.size();
  for (double g : gap) var += (g - mean) * (g - mean) / gap.size();
  const double cv = std::sqrt(var) / mean;
  EXPECT_GT(cv, 0.2) << "gullies evenly spaced (organ pipes): " << centres.size() << " gullies, mean spacing " << mean << " m";

  // The plateau from 60 to 300 m behind the brink: relief and slope spread.
  std::vector<double> pz, ps;
  for (size_t i = 0; i < st.size(); i += 4)
    for (double t = 60; t <= 300; t += 2 * cell) {
      const double x = st[i].x - t * st[i].nx, y = st[i].y - t * st[i].ny;
      if (!inside(x, y, cell)) continue;
      pz.push_back(z(x, y));
      ps.push_back(std::hypot(z(x + cell, y) - z(x - cell, y), z(x, y + cell) - z(x, y - cell)) / (2 * cell));
    }
  ASSERT_GT(pz.size(), 500u);
  const double relief = *std::max_element(pz.begin(), pz.end()) - *std::min_element(pz.begin(), pz.end());
  double ps_mean = 0, ps_var = 0;
  for (double v : ps) ps_mean += v / ps.size();
  for (double v : ps) ps_var += (v - ps_mean) * (v - ps_mean) / ps.size();
  EXPECT_GT(relief, 20.0) << "a flat plateau slab";
  EXPECT_GT(std::sqrt(ps_var), 0.03) << "a featureless plateau (slope std)";

  // The brink: along the chord between the rim's ends, every 20 m, the steepest drop on the chord's
  // normal (+-300 m) marks the face; median over +-60 m (gully notches out), then the RMS of its
  // offset from the best quadratic in the chord's coordinate (a straight or evenly bowed brink: ~0).
  const Vec2 c0 = ctrl.front(), c1 = ctrl.back();
  const double cl = std::hypot(c1.x - c0.x, c1.y - c0.y), ux = (c1.x - c0.x) / cl, uy = (c1.y - c0.y) / cl;
  double vx = -uy, vy = ux;
  if (vx * mid.nx + vy * mid.ny < 0) vx = -vx, vy = -vy;
  std::vector<double> us, off;
  for (double u = 0; u <= cl; u += 20) {
    const double bx = c0.x + u * ux, by = c0.y + u * uy;
    double best = -1, at = 0;
    bool ok = true;
    for (double t = -300; t <= 300; t += cell) {
      const double x = bx + t * vx, y = by + t * vy;
      if (!inside(x, y, 2 * cell)) {
        ok = false;
        break;
      }
      const double drop = z(x, y) - z(x + 2 * cell * vx, y + 2 * cell * vy);
      if (drop > best) best = drop, at = t;
    }
    if (ok) us.push_back(u), off.push_back(at);
  }
  ASSERT_GT(us.size(), 30u);
  std::vector<double> med(off.size());
  for (size_t i = 0; i < off.size(); ++i) {
    std::vector<double> w(off.begin() + std::max<long>(0, long(i) - 3), off.begin() + std::min(off.size(), i + 4));
    std::nth_element(w.begin(), w.begin() + w.size() / 2, w.end());
    med[i] = w[w.size() / 2];
  }
  // Least squares off = a + b u + c u^2 (u scaled to [0, 1]) by the 3x3 normal equations.
  double A[3][4] = {};
  for (size_t i = 0; i < us.size(); ++i) {
    const double p[3] = {1, us[i] / cl, us[i] * us[i] / (cl * cl)};
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) A[j][k] += p[j] * p[k];
      A[j][3] += p[j] * med[i];
    }
  }
  for (int j = 0; j < 3; ++j)
    for (int k = j + 1; k < 3; ++k) {
      const double f = A[k][j] / A[j][j];
      for (int m = j; m < 4; ++m) A[k][m] -= f * A[j][m];
    }
  double coef[3];
  for (int j = 2; j >= 0; --j) {
    coef[j] = A[j][3];
    for (int k = j + 1; k < 3; ++k) coef[j] -= A[j][k] * coef[k];
    coef[j] /= A[j][j];
  }
  double rms = 0;
  for (size_t i = 0; i < us.size(); ++i) {
    const double q = us[i] / cl, e = med[i] - (coef[0] + coef[1] * q + coef[2] * q * q);
    rms += e * e / us.size();
  }
  rms = std::sqrt(rms);
  EXPECT_GT(rms, 16.0) << "a straight brink";
  std::cout << fmt::format("cliff band: {} gullies, spacing mean {:.0f} m cv {:.2f}; plateau relief {:.1f} m slope std {:.3f}; brink wander rms {:.1f} m\n",
                           centres.size(), mean, cv, relief, std::sqrt(ps_var), rms);
}

// The mountain range's ravines form a dendritic network (issue 12: "smooth V troughs without
// gullies"): second-order ravines (narrower than 550 m, ending within 0.6 r of a main ravine's
// axis) join the main ravines at an acute angle pointing downstream, on both sides of most of
// them; third-order gullies join the branches; sub-spurs stand between branches. On the terrain,
// each branch is a valley (across its middle its floor lies >= 0.3 of its nominal depth below its
// banks) that drains: no closed depression deeper than 10 m down its thalweg into the main ravine.
// The former example had none of these (14 main ravines, no branch).
void check_range_network(const nlohmann::json& script, const Heightfield& h, double cell) {
  struct Line {
    std::vector<Vec2> pts;
    std::vector<double> z;  // per-point depths along pts
    double r = 0;
  };
  auto line_of = [&](const nlohmann::json& op) {
    Line l;
    std::vector<Vec2> ctrl;
    std::vector<double> zc;
    for (const auto& q : op.at("points")) ctrl.push_back({double(q[0]), double(q[1])}), zc.push_back(q.size() > 2 ? double(q[2]) : 0.0);
    l.pts = catmull_rom(ctrl, 0.25 * cell, zc, &l.z);
    l.r = 0.5 * double(op.at("width"));
    return l;
  };
  // Distance to a line, the index of its nearest point.
  auto nearest = [](const Line& l, Vec2 p, size_t* at = nullptr) {
    double best = 1e30;
    for (size_t i = 0; i < l.pts.size(); ++i) {
      const double d = std::hypot(l.pts[i].x - p.x, l.pts[i].y - p.y);
      if (d < best) best = d, at ? *at = i : 0;
    }
    return best;
  };
  std::vector<Line> mains, branches;
  std::vector<int> sides;  // per main: bit 0 a branch on its left, bit 1 on its right
  int subspurs = 0;
  for (const auto& op : script.at("operations")) {
    if (op.at("op") == "free_crest" && double(op.at("width")) < 600) ++subspurs;
    if (op.at("op") == "ravine" && double(op.at("width")) >= 550) mains.push_back(line_of(op));
  }
  sides.assign(mains.size(), 0);
  // Third-order gullies end on a wider branch; the other narrow ravines are branches if they end
  // on a main ravine.
  std::vector<Line> narrow;
  for (const auto& op : script.at("operations"))
    if (op.at("op") == "ravine" && double(op.at("width")) < 550) narrow.push_back(line_of(op));
  int acute = 0, third = 0;
  for (const Line& b : narrow) {
    bool on_branch = false;
    for (const Line& o : narrow)
      if (o.r > b.r && nearest(o, b.pts.back()) <= 0.6 * o.r && nearest(o, b.pts.front()) > nearest(o, b.pts.back())) on_branch = true;
    if (on_branch) {
      ++third;
      continue;
    }
    const Vec2 end = b.pts.back(), head = b.pts.front();
    bool joined = false;
    for (size_t m = 0; m < mains.size() && !joined; ++m) {
      size_t k = 0;
      if (nearest(mains[m], end, &k) > 0.6 * mains[m].r || nearest(mains[m], head) <= nearest(mains[m], end)) continue;
      joined = true;
      // The angle between the branch's last stretch (its last r) and the main ravine downstream.
      const Line& M = mains[m];
      const size_t k0 = k ? k - 1 : k, k1 = std::min(k + 1, M.pts.size() - 1);
      const double mx = M.pts[k1].x - M.pts[k0].x, my = M.pts[k1].y - M.pts[k0].y;
      size_t j = b.pts.size() - 1;
      while (j > 0 && std::hypot(b.pts[j].x - end.x, b.pts[j].y - end.y) < b.r) --j;
      const double bx = end.x - b.pts[j].x, by = end.y - b.pts[j].y;
      const double c = (mx * bx + my * by) / (std::hypot(mx, my) * std::hypot(bx, by) + 1e-12);
      acute += c > 0.5;
      sides[m] |= (mx * (head.y - M.pts[k].y) - my * (head.x - M.pts[k].x)) > 0 ? 1 : 2;
    }
    if (joined) branches.push_back(b);
  }
  int both = 0;
  for (int s : sides) both += s == 3;
  ASSERT_GE(mains.size(), 10u);
  EXPECT_GE(2 * branches.size(), 5 * mains.size()) << "main ravines without side branches (2.5 each on average)";
  EXPECT_GE(acute, int(0.9 * branches.size())) << "branches should join at an acute angle pointing downstream";
  EXPECT_GE(both, int(mains.size() / 2)) << "branches on both sides of most main ravines";
  EXPECT_GE(third, 10) << "third-order gullies";
  EXPECT_GE(subspurs, 10) << "sub-spurs between the branches";
  // On the terrain: valleys that drain.
  int valleys = 0, worst_at = -1;
  double worst_pit = 0;
  for (size_t i = 0; i < branches.size(); ++i) {
    const Line& b = branches[i];
    const size_t mid = b.pts.size() / 2;
    const size_t a = mid ? mid - 1 : 0, c = std::min(mid + 1, b.pts.size() - 1);
    const double tx = b.pts[c].x - b.pts[a].x, ty = b.pts[c].y - b.pts[a].y, l = std::hypot(tx, ty);
    const double nx = -ty / l, ny = tx / l;
    std::vector<double> t, z;
    for (double s = -b.r; s <= b.r + 1e-9; s += 0.5 * cell)
      t.push_back(s), z.push_back(at_m(h, cell, b.pts[mid].x + s * nx, b.pts[mid].y + s * ny));
    const double z0 = z.front(), z1 = z.back();
    double floor = 1e30;
    for (size_t q = 0; q < t.size(); ++q)
      if (std::abs(t[q]) <= 0.35 * b.r) floor = std::min(floor, z[q] - (z0 + (z1 - z0) * (t[q] + b.r) / (2 * b.r)));
    const double depth = -floor;  // below the straight line between the banks
    valleys += depth >= 0.3 * b.z[mid];
    // Down the thalweg (the lowest point within 0.4 r across, every half cell) from the head to
    // the branch's last point on the main ravine's wall: the deepest closed depression.
    std::vector<double> th;
    for (size_t q = 0; q < b.pts.size(); q += 2) {  // (pts every quarter cell)
      const size_t qa = q ? q - 1 : 0, qc = std::min(q + 1, b.pts.size() - 1);
      const double ux = b.pts[qc].x - b.pts[qa].x, uy = b.pts[qc].y - b.pts[qa].y, ul = std::hypot(ux, uy);
      double lo = 1e30;
      for (double s = -0.4 * b.r; s <= 0.4 * b.r + 1e-9; s += 0.5 * cell)
        lo = std::min(lo, at_m(h, cell, b.pts[q].x - s * uy / ul, b.pts[q].y + s * ux / ul));
      th.push_back(lo);
    }
    std::vector<double> up(th.size()), down(th.size());
    for (size_t q = 0; q < th.size(); ++q) up[q] = std::max(th[q], q ? up[q - 1] : -1e30);
    for (size_t q = th.size(); q-- > 0;) down[q] = std::max(th[q], q + 1 < th.size() ? down[q + 1] : -1e30);
    for (size_t q = 0; q + 1 < th.size(); ++q)
      if (std::min(up[q], down[q]) - th[q] > worst_pit) worst_pit = std::min(up[q], down[q]) - th[q], worst_at = int(i);
  }
  EXPECT_GE(valleys, int(0.8 * branches.size())) << "branches that are not valleys on the terrain";
  EXPECT_LT(worst_pit, 10.0) << "a pit " << worst_pit << " m deep down the branch from " << branches[std::max(0, worst_at)].pts.front().x << ", "
                              << branches[std::max(0, worst_at)].pts.front().y;
  std::cout << fmt::format("mountain range network: {} main ravines, {} branches ({} joining at an acute angle, {} mains with branches on both sides, "
                           "{} valleys on the terrain), {} third-order gullies, {} sub-spurs; deepest closed depression down a branch {:.1f} m\n",
                           mains.size(), branches.size(), acute, both, valleys, third, subspurs, worst_pit);
}

}  // namespace terracl::test::examples
