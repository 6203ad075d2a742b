// The per-example shape facts of the gallery (edit_example_checks.hpp).
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

namespace {

// Bilinear elevation at a fractional cell (clamped to the grid).
double bilinear_at(const Heightfield& h, double x, double y) {
  const int x0 = std::clamp(int(std::floor(x)), 0, h.width - 2), y0 = std::clamp(int(std::floor(y)), 0, h.height - 2);
  const double tx = std::clamp(x - x0, 0.0, 1.0), ty = std::clamp(y - y0, 0.0, 1.0);
  return (1 - ty) * ((1 - tx) * h.at(x0, y0) + tx * h.at(x0 + 1, y0)) + ty * ((1 - tx) * h.at(x0, y0 + 1) + tx * h.at(x0 + 1, y0 + 1));
}


}  // namespace

void check_shapes(const std::string& name, const nlohmann::json& script, const Heightfield& h, double cell) {
  const double extent = (h.width - 1) * cell;
  if (name == "cliff_turned") {
    EXPECT_TRUE(check_turned_cliff(script, h, cell)) << "the cliff example should run north-south";
    return;
  }
  for (const auto& op : script.at("operations")) {
    const std::string kind = op.at("op");
    // (On the mountain range only its main ravines, 550 m wide or more; check_range_network checks
    // their narrower branches.)
    if (kind == "ravine" && (name == "volcanic_island" || (name == "mountain_range" && double(op.at("width")) >= 550))) {
      // Across the middle of the ravine: depth below its banks at r, and the width of the
      // part below half that depth in cells of the 513^2 run, i.e. pixels of the README's 512-px
      // picture: >= 10 on the island (the former 400 m V ravines: 6, read as scratches), >= 6 on
      // the 15 km mountain range.
      const auto& pts = op.at("points");
      const Stroke m = middle_of(pts);
      const double r = 0.5 * double(op.at("width"));
      // Nominal depth at the middle: per-vertex depths (the island's) or depth_start .. depth.
      const double want = pts[0].size() > 2 ? double(pts[pts.size() / 2][2])
                                            : 0.5 * (double(op.at("depth")) + double(op.at("depth_start")));
      std::vector<double> t, z;
      for (double s = -r; s <= r + 1e-9; s += 0.5 * cell) t.push_back(s), z.push_back(at_m(h, cell, m.mx + s * m.nx, m.my + s * m.ny));
      // Across a flank that also falls sideways (a range's ravine beside a summit) the valley is
      // measured below the straight line between its banks.
      const double z0 = z.front(), z1 = z.back();
      for (size_t i = 0; i < t.size(); ++i) z[i] -= z0 + (z1 - z0) * (t[i] + r) / (2 * r) - std::min(z0, z1);
      double floor = 1e30;
      for (size_t i = 0; i < t.size(); ++i)
        if (std::abs(t[i]) <= 0.25 * r) floor = std::min(floor, z[i]);
      const double depth = std::min(z.front(), z.back()) - floor;
      // The width below half the depth, the depth counted at most as the nominal one: a gully
      // carved along the ravine's floor (the island's drainage operation) deepens its floor, not
      // the valley, and would otherwise measure the notch's width instead of the ravine's.
      const double half_level = std::min(z.front(), z.back()) - 0.5 * std::min(depth, want);
      double below = 0;
      for (double v : z) below += v <= half_level ? 0.5 * cell : 0;
      EXPECT_GT(depth, 0.5 * want) << name << " ravine at " << m.mx << ", " << m.my;
      EXPECT_GE(below, (name == "volcanic_island" ? 10 : 6) * cell) << name << " ravine at " << m.mx << ", " << m.my << ": a scratch, not a valley";
      if (name == "volcanic_island") {
        // The ravine fades out on the seabed: its exit run ends 300 m past the coast point; 1.5 r
        // past it the sea floor across the ravine's line has no trough (the former run-outs cut
        // 60-120 m troughs there).
        const auto &a = pts[pts.size() - 2], &b = pts[pts.size() - 1];
        const double ax = a[0], ay = a[1], bx = b[0], by = b[1], l = std::hypot(bx - ax, by - ay);
        const double ux = (bx - ax) / l, uy = (by - ay) / l, px = bx + 1.5 * r * ux, py = by + 1.5 * r * uy;
        const double mid = at_m(h, cell, px, py);
        const double banks = std::min(at_m(h, cell, px - r * uy, py + r * ux), at_m(h, cell, px + r * uy, py - r * ux));
        EXPECT_LT(banks - mid, 10.0) << "a trough in the sea past the ravine ending at " << bx << ", " << by;
      }
    }
    if (kind == "fit" && name == "volcanic_island") {
      // A volcanic cone: the caldera floor well below its rim and high above the sea, the flanks
      // falling all the way from the rim to the coast (at 50 %, 75 % of the way: lower each time by
      // >= 10 % of the rim's height), the coast at sea level (to 5 m: bilinear between 20 m cells
      // of the 513^2 run) with land inside and sea outside.
      const auto& rim = op.at("ridges").at(0).at("points");
      double cx = 0, cy = 0, rim_top = -1e30;
      for (const auto& q : rim) cx += double(q[0]) / rim.size(), cy += double(q[1]) / rim.size();
      for (const auto& q : rim) rim_top = std::max(rim_top, at_m(h, cell, q[0], q[1]));
      const double floor_z = at_m(h, cell, cx, cy);
      EXPECT_GT(rim_top - floor_z, 150.0) << "no caldera: rim " << rim_top << " m, floor " << floor_z << " m";
      EXPECT_GT(floor_z, 0.5 * rim_top) << "the caldera floor should sit high on the cone";
      for (const auto& c : op.at("contours")) {
        if (double(c.at("elevation")) != 0.0) continue;
        int n_coast = 0;
        for (const auto& q : c.at("points")) {
          const double x = q[0], y = q[1], dx = x - cx, dy = y - cy, l = std::hypot(dx, dy);
          const double ux = dx / l, uy = dy / l;
          EXPECT_NEAR(at_m(h, cell, x, y), 0.0, 5.0) << "coast off sea level at " << x << ", " << y;
          EXPECT_LT(at_m(h, cell, x + 300 * ux, y + 300 * uy), -5.0) << "no sea outside the coast at " << x << ", " << y;
          EXPECT_GT(at_m(h, cell, x - 400 * ux, y - 400 * uy), 5.0) << "no land inside the coast at " << x << ", " << y;
          // The flank from the rim (its nearest vertex in this direction) down to the coast.
          double best = -1, rx = cx, ry = cy;
          for (const auto& v : rim) {
            const double vx = double(v[0]) - cx, vy = double(v[1]) - cy, dot = (vx * ux + vy * uy) / std::hypot(vx, vy);
            if (dot > best) best = dot, rx = v[0], ry = v[1];
          }
          const double z0 = at_m(h, cell, rx, ry);
          // The highest point across the flank within 300 m (a ravine may run under the line).
          auto across = [&](double f) {
            const double px = (1 - f) * rx + f * x, py = (1 - f) * ry + f * y;
            double top = -1e30;
            for (double s = -300; s <= 300; s += cell) top = std::max(top, at_m(h, cell, px - s * uy, py + s * ux));
            return top;
          };
          const double z50 = across(0.5), z75 = across(0.75);
          EXPECT_LT(z50, z0 - 0.1 * rim_top) << "flank towards " << x << ", " << y;
          EXPECT_LT(z75, z50 - 0.1 * rim_top) << "flank towards " << x << ", " << y;
          ++n_coast;
        }
        EXPECT_GE(n_coast, 24);
      }
    }
    if (kind == "ravine" && name == "cliff") {
      // A couloir starts on the brink: on the plateau a quarter of its half-width above the rim
      // (the smoothed cliff line, at the couloir's x) the ground across its line is level, no
      // hollow (the former couloirs started 100-170 m above the rim: dark blobs on the plateau).
      std::vector<Vec2> rim_pts;
      for (const auto& o : script.at("operations"))
        if (o.at("op") == "cliff")
          for (const auto& q : o.at("points")) rim_pts.push_back({double(q[0]), double(q[1])});
      const auto rim = catmull_rom(rim_pts, 5.0);
      const double r = 0.5 * double(op.at("width")), x0 = op.at("points")[0][0];
      double rim_y = 0, best = 1e30;
      for (const auto& q : rim)
        if (std::abs(q.x - x0) < best) best = std::abs(q.x - x0), rim_y = q.y;
      // A notch starts back on the plateau (north of the rim, y grows southwards): its hollow is meant.
      if (double(op.at("points")[0][1]) < rim_y - 5) continue;
      const double up = rim_y - 0.25 * r;  // north (y grows southwards)
      const double mid = at_m(h, cell, x0, up);
      const double banks = std::min(at_m(h, cell, x0 - r, up), at_m(h, cell, x0 + r, up));
      // (5 m: a chute that notches the brink (cut_rims releases the rim within r of it) lets the
      // brink sag over its head: 2.4 m at 0.25 r for the deepest chute, 92 m wide and 21 m deep at
      // the brink, -0.1 m without it; the former couloirs' hollows were 20-41 m.)
      EXPECT_LT(banks - mid, 5.0) << "a couloir hollow above the rim at x = " << x0;
    }
    if (kind == "cliff" && name == "cliff") {
      // Down the fall line from the brink midway between the two gullies nearest to the map's middle
      // (their cones break the apron): a face steeper than 45 degrees dropping at least a third of
      // the height, then a scree apron (slopes 0.25..0.85) over >= 8 % of the map. The gullies start
      // on the rim: the chord between their heads gives the rim's direction there.
      // Each gully (a ravine with a point on the face's side of the smoothed rim; the plateau valleys
      // feeding the notches have none) is placed at the rim station nearest to it; the fall line starts
      // on the rim midway (in arc) between the two around the map's middle, along the rim's normal.
      std::vector<Vec2> ctrl;
      for (const auto& q : op.at("points")) ctrl.push_back({double(q[0]), double(q[1])});
      const auto rim = catmull_rom(ctrl, 5.0);
      auto normal_at = [&](size_t k) {
        k = std::clamp<size_t>(k, 1, rim.size() - 2);
        const double len = std::hypot(rim[k + 1].x - rim[k - 1].x, rim[k + 1].y - rim[k - 1].y);
        return Vec2{-(rim[k + 1].y - rim[k - 1].y) / len, (rim[k + 1].x - rim[k - 1].x) / len};
      };
      Vec2 down = normal_at(rim.size() / 2);
      {
        const Vec2 q = rim[rim.size() / 2];
        if (at_m(h, cell, q.x + 50 * down.x, q.y + 50 * down.y) > at_m(h, cell, q.x - 50 * down.x, q.y - 50 * down.y)) down = {-down.x, -down.y};
      }
      std::vector<size_t> heads;
      for (const auto& o : script.at("operations")) {
        if (o.at("op") != "ravine") continue;
        size_t best_k = 0;
        double best = 1e30, face_side = -1e30;
        for (const auto& q : o.at("points")) {
          const double px = q[0], py = q[1];
          for (size_t i = 1; i + 1 < rim.size(); ++i) {
            const double d = std::hypot(px - rim[i].x, py - rim[i].y);
            if (d < best) best = d, best_k = i;
          }
        }
        for (const auto& q : o.at("points"))
          face_side = std::max(face_side, (double(q[0]) - rim[best_k].x) * down.x + (double(q[1]) - rim[best_k].y) * down.y);
        if (face_side > 0) heads.push_back(best_k);
      }
      std::sort(heads.begin(), heads.end(), [&](size_t a, size_t b) { return rim[a].x < rim[b].x; });
      ASSERT_GE(heads.size(), 2u) << "the cliff example has gullies";
      size_t g = 0;
      while (g + 2 < heads.size() && rim[heads[g + 1]].x < 0.5 * extent) ++g;
      const size_t k = (heads[g] + heads[g + 1]) / 2;
      const Vec2 nk = normal_at(k);
      double nx = nk.x, ny = nk.y;
      const double ox = rim[k].x, oy = rim[k].y;
      if (at_m(h, cell, ox + 50 * nx, oy + 50 * ny) > at_m(h, cell, ox - 50 * nx, oy - 50 * ny)) nx = -nx, ny = -ny;
      // Samples every cell down the fall line, from 40 m back on the plateau.
      std::vector<double> z;
      for (double t = -40; t < 0.5 * extent; t += cell) z.push_back(at_m(h, cell, ox + t * nx, oy + t * ny));
      const int n = int(z.size());
      const double top = op.at("elevation"), height = op.at("height");
      int y = 0;
      while (y + 1 < n && z[y] > top - 5) ++y;
      auto slope = [&](int i) { return (z[i] - z[i + 1]) / cell; };
      int steep = y;
      for (int i = y; i < std::min(n - 1, y + int(0.15 * extent / cell)); ++i)
        if (slope(i) > slope(steep)) steep = i;
      EXPECT_GT(slope(steep), 1.0) << "no steep face";
      // The face runs on over its ledges (strata: gentler runs shorter than 16 m between its cliff
      // bands) down to the foot.
      int foot = y;
      while (foot + 1 < n) {
        if (slope(foot) > 0.8) {
          ++foot;
          continue;
        }
        int j = foot;
        while (j + 1 < n && slope(j) <= 0.8 && (j - foot) * cell < 16) ++j;
        if (j + 1 >= n || slope(j) <= 0.8 || foot < steep - int(0.1 * extent / cell)) break;
        foot = j;
      }
      foot = std::max(foot, steep);
      EXPECT_GT(z[y] - z[foot], height / 3) << "the face drops too little";
      // Ledges (strata): runs of cells gentler than half the steeper of the cliff bands within 16 m
      // above and below, both bands steeper than 2.5; >= 2 of them between the brink and the foot (3 today;
      // the former face, one smooth wall under a steepened cap: 0).
      int ledges = 0;
      const int reach = std::max(1, int(16 / cell));
      bool in_ledge = false;
      for (int i = y + 1; i < foot; ++i) {
        double above = 0, below = 0;
        for (int k = std::max(y, i - reach); k < i; ++k) above = std::max(above, slope(k));
        for (int k = i + 1; k <= std::min(n - 2, i + reach); ++k) below = std::max(below, slope(k));
        const double band = std::min(above, below);
        const bool ledge = band > 2.5 && slope(i) < 0.5 * band;
        ledges += ledge && !in_ledge;
        in_ledge = ledge;
      }
      EXPECT_GE(ledges, 2) << "no ledges on the face (strata)";

      std::cout << fmt::format("cliff: {} ledges down the face, which drops {:.0f} m\n", ledges, z[y] - z[foot]);
      // (The apron's slope over 16 m: the ridged gullies oriented down it ripple a one-cell slope.)
      auto apron = [&](int i) { return (z[i] - z[std::min(n - 1, i + 4)]) / (4 * cell); };
      // (A fallen block on the fall line interrupts the apron for less than 24 m.)
      auto on_apron = [&](int i) { return apron(i) >= 0.25 && apron(i) <= 0.85; };
      int toe = foot;
      while (toe + 4 < n) {
        if (on_apron(toe)) {
          ++toe;
          continue;
        }
        int j = toe;
        while (j + 4 < n && !on_apron(j) && (j - toe) * cell < 24) ++j;
        if (j + 4 >= n || !on_apron(j)) break;
        toe = j;
      }
      EXPECT_GE((toe - foot) * cell, 0.08 * extent) << "the scree apron is too narrow to read (from " << ox << ", " << oy << ")";
      // The apron's top, 60 m below the face's foot, lies near the repose angle of scree (33-37
      // degrees: slope 0.65-0.75): its mean slope within 30-39 degrees.
      double top_slope = 0;
      const int m = int(60 / cell);
      for (int i = foot; i < foot + m; ++i) top_slope += apron(std::min(i, n - 5)) / m;
      EXPECT_GT(top_slope, 0.58) << "the scree's top is gentler than its repose angle";
      EXPECT_LT(top_slope, 0.8) << "the scree's top is steeper than its repose angle";
      std::cout << fmt::format("cliff: face {:.2f} at its steepest, scree top {:.2f} over 60 m\n", slope(steep), top_slope);
      check_cliff_band(op, h, cell);
    }
    if (kind == "mountain_range" && name == "mountain_range") {
      check_range_network(script, h, cell);
      // At stations every 400 m along the smoothed stroke, wherever it is above 900 m (summits,
      // cols and the slopes between): the crest is the highest point across the stroke within 0.3 r
      // (to 6 % of r: the noise moves it a little) and stands at least 15 % of its height above
      // both sides. The summits and cols are checked against the heights given at the vertices.
      const auto& pts = op.at("points");
      const double r = 0.5 * double(op.at("width"));
      std::vector<Vec2> ctrl;
      std::vector<double> zc, zs;
      for (const auto& q : pts) ctrl.push_back({double(q[0]), double(q[1])}), zc.push_back(double(q[2]));
      const auto line = catmull_rom(ctrl, 10.0, zc, &zs);
      int checked = 0;
      double since = 1e30, total = 0, arc = 0;
      for (size_t i = 1; i < line.size(); ++i) total += std::hypot(line[i].x - line[i - 1].x, line[i].y - line[i - 1].y);
      for (size_t i = 1; i + 1 < line.size(); ++i) {
        const double step = std::hypot(line[i].x - line[i - 1].x, line[i].y - line[i - 1].y);
        since += step, arc += step;
        // (Not within the stroke's taper, r of arc from either end, which lowers the crest.)
        if (since < 400 || zs[i] < 900 || arc < r || total - arc < r) continue;
        since = 0;
        const double tx = line[i + 1].x - line[i - 1].x, ty = line[i + 1].y - line[i - 1].y, l = std::hypot(tx, ty);
        const double nx = -ty / l, ny = tx / l;
        double best = -1e30, best_t = 0;
        for (double s = -0.3 * r; s <= 0.3 * r; s += 0.5 * cell) {
          const double v = at_m(h, cell, line[i].x + s * nx, line[i].y + s * ny);
          if (v > best) best = v, best_t = s;
        }
        EXPECT_LE(std::abs(best_t), 0.06 * r) << "crest off its line at " << line[i].x << ", " << line[i].y;
        const double side = std::max(at_m(h, cell, line[i].x + 0.3 * r * nx, line[i].y + 0.3 * r * ny),
                                     at_m(h, cell, line[i].x - 0.3 * r * nx, line[i].y - 0.3 * r * ny));
        EXPECT_GT(best - side, 0.15 * zs[i]) << "no ridge at " << line[i].x << ", " << line[i].y;
        ++checked;
      }
      EXPECT_GE(checked, 20);
      // Summits and cols: the crest's height at the vertices follows the given heights (the noise
      // adds up to about its amplitude), so a col is lower than both summits beside it.
      std::vector<double> crest;
      for (const auto& q : pts) {
        double top = -1e30;
        for (double dy = -0.06 * r; dy <= 0.06 * r; dy += 0.5 * cell)
          for (double dx = -0.06 * r; dx <= 0.06 * r; dx += 0.5 * cell) top = std::max(top, at_m(h, cell, double(q[0]) + dx, double(q[1]) + dy));
        crest.push_back(top);
      }
      // Vertices 1, 3, ... are the cols; the first two summits and the last are within the
      // stroke's taper (r of arc from its ends), lowered by it.
      int cols = 0;
      for (size_t i = 6; i + 4 < pts.size(); i += 2, ++cols)
        EXPECT_LT(crest[i - 1], std::min(crest[i - 2], crest[i]) - 100) << "no col between summits " << i - 2 << " and " << i;
      EXPECT_GE(cols, 3);
      // The crest reads as one line from peak to peak, not a row of pyramids: each inner col
      // stands above 0.85 of the lower summit beside it (0.86-0.88; the former range's: 0.78-0.84, each
      // summit a cone rising from near the plain).
      for (size_t i = 6; i + 4 < pts.size(); i += 2)
        EXPECT_GT(crest[i - 1], 0.85 * std::min(crest[i - 2], crest[i])) << "col " << i - 1 << " drops too deep: " << crest[i - 1] << " m between " << crest[i - 2] << " and " << crest[i];
      // Spurs (the free_crests rooted within 0.15 r of the crest line, narrower than the stroke):
      // of varied length (the longest >= 2x the shortest) and unevenly spaced along each flank
      // (coefficient of variation of the spacing >= 0.4; the former comb teeth: lengths
      // 0.6-0.95 r, 0.31 and 0.36 on its two flanks).
      std::vector<double> lens, arc_at(line.size(), 0.0);
      for (size_t i = 1; i < line.size(); ++i) arc_at[i] = arc_at[i - 1] + std::hypot(line[i].x - line[i - 1].x, line[i].y - line[i - 1].y);
      std::vector<double> roots[2];
      struct SpurLine {
        std::vector<Vec2> pts;
        double crest_z;  // the crest's relief at its root (the stroke's per-vertex z)
      };
      std::vector<SpurLine> spur_lines;
      for (const auto& o : script.at("operations")) {
        if (o.at("op") != "free_crest" || double(o.at("width")) >= 2 * r || double(o.at("width")) < 600) continue;  // (not the sub-spurs)
        const auto& q = o.at("points");
        const double qx = q[0][0], qy = q[0][1];
        size_t k = 0;
        double d = 1e30;
        for (size_t i = 0; i < line.size(); ++i)
          if (std::hypot(line[i].x - qx, line[i].y - qy) < d) d = std::hypot(line[i].x - qx, line[i].y - qy), k = i;
        if (d > 0.15 * r) continue;
        double len = 0;
        for (size_t j = 1; j < q.size(); ++j) len += std::hypot(double(q[j][0]) - double(q[j - 1][0]), double(q[j][1]) - double(q[j - 1][1]));
        lens.push_back(len);
        SpurLine sl{{}, zs[k]};
        for (const auto& p : q) sl.pts.push_back({double(p[0]), double(p[1])});
        spur_lines.push_back(sl);
        const size_t k0 = k ? k - 1 : k, k1 = std::min(k + 1, line.size() - 1);
        const double cross = (line[k1].x - line[k0].x) * (double(q.back()[1]) - qy) - (line[k1].y - line[k0].y) * (double(q.back()[0]) - qx);
        roots[cross > 0].push_back(arc_at[k]);
      }
      ASSERT_GE(lens.size(), 10u) << "the range has spurs";
      EXPECT_GE(*std::max_element(lens.begin(), lens.end()), 2 * *std::min_element(lens.begin(), lens.end())) << "spurs of one length";
      for (auto& rs : roots) {
        std::sort(rs.begin(), rs.end());
        ASSERT_GE(rs.size(), 4u);
        double m = 0, v = 0;
        for (size_t i = 1; i < rs.size(); ++i) m += (rs[i] - rs[i - 1]) / (rs.size() - 1);
        for (size_t i = 1; i < rs.size(); ++i) v += (rs[i] - rs[i - 1] - m) * (rs[i] - rs[i - 1] - m) / (rs.size() - 1);
        EXPECT_GE(std::sqrt(v) / m, 0.4) << "spurs evenly spaced along a flank (comb teeth): " << std::sqrt(v) / m;
      }
      // The flanks are ribbed, not a smooth sausage with scratches (range4 round): across the middle
      // of each spur, its top (within 150 m of its line) stands above the valleys on both sides (the
      // higher of the lowest points within 1 km either side) by >= 0.1 of the crest's relief at its
      // root (0.12 today, median 0.24; the former range: 0.04, median 0.21, its weakest spur a
      // shoulder on the smooth flank).
      std::vector<double> rel;
      for (const auto& sp : spur_lines) {
        const auto pl = catmull_rom(sp.pts, 20.0);
        double tot = 0, acc = 0;
        for (size_t i = 1; i < pl.size(); ++i) tot += std::hypot(pl[i].x - pl[i - 1].x, pl[i].y - pl[i - 1].y);
        size_t k = 1;
        for (; k + 2 < pl.size() && acc < 0.5 * tot; ++k) acc += std::hypot(pl[k].x - pl[k - 1].x, pl[k].y - pl[k - 1].y);
        const double tx = pl[k + 1].x - pl[k - 1].x, ty = pl[k + 1].y - pl[k - 1].y, l = std::hypot(tx, ty);
        const double nx = -ty / l, ny = tx / l;
        double top = -1e30, lo[2] = {1e30, 1e30};
        for (double s = -150; s <= 150; s += 0.5 * cell) top = std::max(top, at_m(h, cell, pl[k].x + s * nx, pl[k].y + s * ny));
        for (int sg = 0; sg < 2; ++sg)
          for (double s = 0; s <= 1000; s += 0.5 * cell)
            lo[sg] = std::min(lo[sg], at_m(h, cell, pl[k].x + (sg ? -s : s) * nx, pl[k].y + (sg ? -s : s) * ny));
        rel.push_back((top - std::max(lo[0], lo[1])) / sp.crest_z);
      }
      std::sort(rel.begin(), rel.end());
      EXPECT_GE(rel.front(), 0.1) << "a spur that does not stand out of the flank";
      // The foothills hang off the range (range4 round): every other ridge of >= 600 m (forks and
      // foothills: free_crests narrower than the stroke not rooted on the crest line) starts within
      // 400 m of a spur, and its crest (the highest point within 90 m across) from its start to its
      // highest vertex dips nowhere more than 40 m below the lower of the two (no saddle cutting it
      // off: 22 m today). The former foothills stood alone on the plain, 2.5-4.6 km from any spur.
      int foothills = 0;
      double worst_gap = 0, worst_dip = 0;
      for (const auto& o : script.at("operations")) {
        if (o.at("op") != "free_crest" || double(o.at("width")) >= 2 * r || double(o.at("width")) < 600) continue;
        const auto& q = o.at("points");
        const Vec2 q0{double(q[0][0]), double(q[0][1])};
        double d = 1e30;
        for (const auto& p : line) d = std::min(d, std::hypot(p.x - q0.x, p.y - q0.y));
        if (d <= 0.15 * r) continue;  // a spur
        ++foothills;
        double gap = 1e30;
        for (const auto& sp : spur_lines)
          for (size_t j = 1; j < sp.pts.size(); ++j) {
            const Vec2 a = sp.pts[j - 1], b = sp.pts[j];
            const double dx = b.x - a.x, dy = b.y - a.y;
            const double t = std::clamp(((q0.x - a.x) * dx + (q0.y - a.y) * dy) / (dx * dx + dy * dy + 1e-9), 0.0, 1.0);
            gap = std::min(gap, std::hypot(q0.x - a.x - t * dx, q0.y - a.y - t * dy));
          }
        worst_gap = std::max(worst_gap, gap);
        EXPECT_LE(gap, 400.0) << "a foothill or fork standing alone, " << gap << " m from the nearest spur, at " << q0.x << ", " << q0.y;
        std::vector<Vec2> ctrl_q;
        size_t top_i = 0;
        for (size_t j = 0; j < q.size(); ++j) {
          ctrl_q.push_back({double(q[j][0]), double(q[j][1])});
          if (double(q[j][2]) > double(q[top_i][2])) top_i = j;
        }
        const auto pl = catmull_rom(ctrl_q, 30.0);
        std::vector<double> prof;
        for (size_t k = 1; k + 1 < pl.size(); ++k) {
          const double tx = pl[k + 1].x - pl[k - 1].x, ty = pl[k + 1].y - pl[k - 1].y, l = std::hypot(tx, ty);
          double top = -1e30;
          for (double s = -90; s <= 90; s += 0.5 * cell) top = std::max(top, at_m(h, cell, pl[k].x - s * ty / l, pl[k].y + s * tx / l));
          prof.push_back(top);
          if (std::hypot(pl[k].x - ctrl_q[top_i].x, pl[k].y - ctrl_q[top_i].y) < 30) break;
        }
        if (prof.size() < 3) continue;
        const double dip = std::min(prof.front(), prof.back()) - *std::min_element(prof.begin(), prof.end());
        worst_dip = std::max(worst_dip, dip);
        EXPECT_LE(dip, 40.0) << "a saddle cuts the foothill or fork at " << q0.x << ", " << q0.y << " off its spur";
      }
      EXPECT_GE(foothills, 6) << "the range has forks and foothills";
      std::cout << fmt::format("mountain range spurs: relief / crest relief {:.2f} (least) {:.2f} (median) of {}; {} forks and foothills, "
                               "farthest {:.0f} m from a spur, deepest saddle {:.1f} m\n",
                               rel.front(), rel[rel.size() / 2], rel.size(), foothills, worst_gap, worst_dip);
    }
    if (kind == "cliff" && name == "canyon") {
      // The walls are layered rock (strata): down the fall line from the rim, at every rim station on
      // the map and 400 m or more from where a side canyon cuts the rim, >= 3 cliff bands (runs
      // steeper than 1.2 that drop >= 20 m) with a bench (gentler than 0.7) between each pair. The
      // former walls, one smooth face over scree, had one band.
      std::vector<Vec2> heads;
      for (const auto& c : canyon_cuts(script, h, cell)) heads.insert(heads.end(), c.stations.begin(), c.stations.end());
      // (Every 200 m along the smoothed rim since canyon round 4: the drainage's side canyons leave
      // fewer of the rim's vertices, 445 m apart, 400 m from a cut.)
      std::vector<Vec2> ctrl, pts;
      for (const auto& q : op.at("points")) ctrl.push_back({double(q[0]), double(q[1])});
      for (const auto& v : catmull_rom(ctrl, 5.0))
        if (pts.empty() || std::hypot(v.x - pts.back().x, v.y - pts.back().y) >= 200) pts.push_back(v);
      int walls = 0, layered = 0;
      for (size_t i = 1; i + 1 < pts.size(); ++i) {
        const double px = pts[i].x, py = pts[i].y;
        if (px < 200 || py < 200 || px > extent - 200 || py > extent - 200) continue;
        bool near = false;
        for (const auto& q : heads) near = near || std::hypot(q.x - px, q.y - py) < 400;
        if (near) continue;
        double nx = -(pts[i + 1].y - pts[i - 1].y), ny = pts[i + 1].x - pts[i - 1].x;
        const double l = std::hypot(nx, ny);
        nx /= l, ny /= l;
        if (at_m(h, cell, px + 100 * nx, py + 100 * ny) > at_m(h, cell, px - 100 * nx, py - 100 * ny)) nx = -nx, ny = -ny;
        std::vector<double> z;
        for (double t = -30; t <= 700; t += cell) z.push_back(at_m(h, cell, px + t * nx, py + t * ny));
        int bands = 0, benches = 0, gentle = 0;
        double drop = 0;
        bool in_band = false;
        for (size_t k = 0; k + 1 < z.size(); ++k) {
          const double s = (z[k] - z[k + 1]) / cell;
          if (s > 1.2) {
            if (!in_band && drop == 0 && bands > 0 && gentle >= 1) ++benches;
            drop += z[k] - z[k + 1], in_band = true, gentle = 0;
          } else {
            if (in_band && drop >= 20) ++bands;
            if (in_band) drop = 0;
            in_band = false;
            gentle += s < 0.7 ? 1 : 0;
          }
        }
        ++walls;
        layered += bands >= 3 && benches >= 2;
        std::cout << fmt::format("canyon wall at {:.0f}, {:.0f}: {} cliff bands, {} benches between\n", px, py, bands, benches);
      }
      ASSERT_GE(walls, 3);  // (3 on the east rim, cut by four side canyons)
      EXPECT_GE(layered, (walls * 2 + 2) / 3) << "canyon walls without strata (of " << walls << ")";
    }
    if (kind == "river" && name == "canyon" && double(op.at("width")) >= 200) {
      // No pit along the canyon's river: down the thalweg (the lowest point across the bed within
      // r, every half cell along the smoothed river) no closed depression deeper than 3 m (the
      // depth of water it would hold: min(highest point upstream, highest downstream) - z). The
      // former side canyons, still 170 m deep at their ends, ran on into the floor and dug pits by
      // the river 15-40 m deep.
      const auto& pts = op.at("points");
      std::vector<Vec2> ctrl;
      for (const auto& q : pts) ctrl.push_back({double(q[0]), double(q[1])});
      const auto line = catmull_rom(ctrl, 0.5 * cell);
      const double r = 0.5 * double(op.at("width"));
      std::vector<double> z;
      for (size_t i = 1; i + 1 < line.size(); ++i) {
        if (line[i].x < 0 || line[i].y < 0 || line[i].x > extent || line[i].y > extent) continue;
        const double tx = line[i + 1].x - line[i - 1].x, ty = line[i + 1].y - line[i - 1].y, l = std::hypot(tx, ty);
        double lo = 1e30;
        for (double s = -r; s <= r; s += 0.5 * cell) lo = std::min(lo, at_m(h, cell, line[i].x - s * ty / l, line[i].y + s * tx / l));
        z.push_back(lo);
      }
      ASSERT_GT(z.size(), 100u);
      std::vector<double> up(z.size()), down(z.size());
      for (size_t i = 0; i < z.size(); ++i) up[i] = std::max(z[i], i ? up[i - 1] : -1e30);
      for (size_t i = z.size(); i-- > 0;) down[i] = std::max(z[i], i + 1 < z.size() ? down[i + 1] : -1e30);
      double worst = 0;
      size_t at = 0;
      for (size_t i = 0; i < z.size(); ++i)
        if (std::min(up[i], down[i]) - z[i] > worst) worst = std::min(up[i], down[i]) - z[i], at = i;
      EXPECT_LT(worst, 3.0) << "a pit " << worst << " m deep along the canyon's river (sample " << at << " of " << z.size() << ")";
    }
  }
  if (name == "canyon") {
    // Canyon round 4: the side canyons are carved by the plateau's drainage (one `drainage` op,
    // canyon section; its polygon is the plateaus and walls, the main floor left out).
    // Side canyons cut both rims: >= 5 cuts >= 250 m below the rim (8 today, 4 west and 4 east),
    // >= 2 on each rim, and their widths along the rim differ (the widest >= 2x the narrowest:
    // 180-520 m today, 2.9x; the former drawn side canyons, by the same rule in a Python replica
    // of this check, 460-1040 m, 2.3x).
    const auto cuts = canyon_cuts(script, h, cell);
    int per_rim[2] = {0, 0};
    double w_lo = 1e30, w_hi = 0;
    for (const auto& c : cuts) {
      per_rim[std::min(c.rim, 1)]++;
      w_lo = std::min(w_lo, c.width()), w_hi = std::max(w_hi, c.width());
      const Vec2& m = c.stations[c.stations.size() / 2];
      std::cout << fmt::format("side canyon cutting rim {} at {:.0f}, {:.0f}: {:.0f} m wide along the rim, floor {:.0f} m\n", c.rim, m.x, m.y,
                               c.width(), c.lowest);
    }
    EXPECT_GE(cuts.size(), 5u) << "side canyons cutting the rims";
    EXPECT_GE(per_rim[0], 2) << "side canyons cutting the first rim";
    EXPECT_GE(per_rim[1], 2) << "side canyons cutting the second rim";
    EXPECT_GE(w_hi, 2.0 * w_lo) << "the side canyons are all one width";
    const nlohmann::json* drainage = nullptr;
    for (const auto& o : script.at("operations"))
      if (o.at("op") == "drainage") drainage = &o;
    ASSERT_NE(drainage, nullptr) << "the canyon's side canyons come from a drainage op";
    const auto& poly = drainage->at("polygon");
    // Their floors drain: within the drainage op's polygon the priority-flood fill raises no cell by
    // more than 16 m (5.6 m today; the drainage op alone leaves 0.6 m, the strata's steps on the
    // side canyons' steep floors make the rest, 5.6-14.4 m depending on where the bands fall; the
    // former drawn side canyons 24.7 m beside a mouth).
    const Heightfield filled = analysis::priority_flood_fill(h).filled;
    double worst = 0, wx = 0, wy = 0;
    for (int j = 0; j < h.height; ++j)
      for (int i = 0; i < h.width; ++i) {
        const double d = double(filled.at(i, j)) - double(h.at(i, j));
        if (d > worst && in_polygon(poly, i * cell, j * cell)) worst = d, wx = i * cell, wy = j * cell;
      }
    std::cout << fmt::format("canyon: deepest closed hollow in the side canyons' region {:.1f} m (at {:.0f}, {:.0f})\n", worst, wx, wy);
    EXPECT_LT(worst, 16.0) << "a closed hollow " << worst << " m deep at " << wx << ", " << wy;
    // They branch: D8 channels (the op's threshold area) inside the polygon and below 700 m (cut
    // >= 100 m into the 800-920 m plateau) join at >= 45 junctions (59 today; the former drawn side
    // canyons, with their washes and tributary ravines, 31, by a Python replica of this check).
    Heightfield hz = h;
    hz.georef.cell_x = hz.georef.cell_y = cell;
    const analysis::D8Result flow = analysis::d8_flow(analysis::priority_flood_fill(hz, true).filled);
    const double thr = double(drainage->at("threshold")) / (cell * cell);
    std::vector<int> donors(size_t(h.width) * h.height, 0);
    for (int j = 0; j < h.height; ++j)
      for (int i = 0; i < h.width; ++i) {
        const size_t k = size_t(j) * h.width + i;
        if (flow.cells[k] < thr || flow.dir[k] >= 8) continue;
        donors[size_t(j + analysis::kDy[flow.dir[k]]) * h.width + i + analysis::kDx[flow.dir[k]]]++;
      }
    int junctions = 0;
    for (int j = 0; j < h.height; ++j)
      for (int i = 0; i < h.width; ++i) {
        const size_t k = size_t(j) * h.width + i;
        junctions += donors[k] >= 2 && flow.cells[k] >= thr && h.at(i, j) < 700 && in_polygon(poly, i * cell, j * cell);
      }
    std::cout << fmt::format("canyon: {} junctions of the side canyons' channels\n", junctions);
    EXPECT_GE(junctions, 45) << "the side canyons do not branch";
    // The main river runs in a narrow inner gorge: at every vertex on the map the terrain 150 m
    // either side stands >= 50 m above the bed (the lowest within 20 m) (57 m at least today, 72
    // before the strata's beds were thinned; the former river, 420 m wide with 10 m banks: 18-80 m).
    for (const auto& o : script.at("operations")) {
      if (o.at("op") != "river" || double(o.at("width")) < 200) continue;
      const auto& q = o.at("points");
      double least = 1e30;
      for (size_t k = 1; k + 1 < q.size(); ++k) {
        const double x = q[k][0], y = q[k][1];
        if (y < 100 || y > extent - 100) continue;
        const double tx = double(q[k + 1][0]) - double(q[k - 1][0]), ty = double(q[k + 1][1]) - double(q[k - 1][1]), l = std::hypot(tx, ty);
        const double nx = -ty / l, ny = tx / l;
        double bed = 1e30;
        for (double t = -20; t <= 20; t += 5) bed = std::min(bed, at_m(h, cell, x + t * nx, y + t * ny));
        least = std::min(least, std::min(at_m(h, cell, x - 150 * nx, y - 150 * ny), at_m(h, cell, x + 150 * nx, y + 150 * ny)) - bed);
      }
      std::cout << fmt::format("canyon: inner gorge at least {:.0f} m deep 150 m out\n", least);
      EXPECT_GE(least, 50.0) << "the main river has no inner gorge";
    }
  }
}

// The river valley (scripts/gen-river-valley.py; its widest `river` is the valley, a narrow one the
// channel in its floor):
// - it opens onto the plains flush with them: in the valley's outer bank zone (0.5 r to 1.5 r from the
//   smoothed river) wherever the base DEM is below 1700 m, no cell stands more than 10 m above the
//   unedited DEM (the former 280 m banks lifted that zone by up to 214 m: a raised lobe on the plain);
// - its floor is a flood plain: across +-6 cells of the path in the mountains (west of x = 600) the
//   median range of elevations is under 0.3 of the DEM's there (0.18; the former example, whose
//   floor kept the DEM's own ridges crossing it and read as a trench, 0.54);
// - the floor falls downstream: along the path, no rise over 10 cells of more than 5 m.
void check_river_valley(const nlohmann::json& script, const Heightfield& h) {
  const Heightfield base = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  ASSERT_EQ(base.size(), h.size());
  const nlohmann::json* valley = nullptr;
  for (const auto& op : script.at("operations"))
    if (op.at("op") == "river" && (!valley || double(op.at("width")) > double(valley->at("width")))) valley = &op;
  ASSERT_NE(valley, nullptr);
  std::vector<Vec2> ctrl;
  for (const auto& q : valley->at("points")) ctrl.push_back({double(q[0]), double(q[1])});
  const auto line = catmull_rom(ctrl, 1.0);
  const double r = 0.5 * double(valley->at("width"));
  double worst = -1e30;
  size_t n = 0;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      if (!(base.at(x, y) < 1700.0f)) continue;
      double d = 1e30;
      for (const auto& q : line) d = std::min(d, std::hypot(q.x - x, q.y - y));
      if (d < 0.5 * r || d > 1.5 * r) continue;
      ++n, worst = std::max(worst, double(h.at(x, y)) - base.at(x, y));
    }
  EXPECT_GT(n, 2000u) << "the river should reach the plains";
  EXPECT_LE(worst, 10.0) << "the river valley's banks stand as a raised lobe on the plain";

  std::vector<double> across_after, across_base, floor_z;
  for (size_t k = 1; k + 1 < line.size(); ++k) {
    const Vec2 p = line[k];
    if (p.x > h.width - 1.0) break;
    floor_z.push_back(bilinear_at(h, p.x, p.y));
    if (p.x > 600) continue;
    const double tx = line[k + 1].x - line[k - 1].x, ty = line[k + 1].y - line[k - 1].y, l = std::hypot(tx, ty);
    const double nx = -ty / l, ny = tx / l;
    double lo_a = 1e30, hi_a = -1e30, lo_b = 1e30, hi_b = -1e30;
    for (int o = -6; o <= 6; ++o) {
      const double za = bilinear_at(h, p.x + o * nx, p.y + o * ny), zb = bilinear_at(base, p.x + o * nx, p.y + o * ny);
      lo_a = std::min(lo_a, za), hi_a = std::max(hi_a, za), lo_b = std::min(lo_b, zb), hi_b = std::max(hi_b, zb);
    }
    across_after.push_back(hi_a - lo_a), across_base.push_back(hi_b - lo_b);
  }
  ASSERT_GT(across_after.size(), 200u);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double flat_after = median(across_after), flat_base = median(across_base);
  EXPECT_LT(flat_after, 0.3 * flat_base) << "the valley floor should be a flood plain, not the DEM's ridges";
  double rise = -1e30;
  for (size_t k = 0; k + 10 < floor_z.size(); k += 10) rise = std::max(rise, floor_z[k + 10] - floor_z[k]);
  EXPECT_LE(rise, 5.0) << "the valley floor should fall downstream";
  std::cout << fmt::format(
      "river valley: {} cells of the outer bank zone on the plains, highest {:.1f} m above the DEM; floor across "
      "+-6 cells {:.1f} m (DEM {:.1f} m, median); largest rise downstream over 10 cells {:.1f} m\n",
      n, worst, flat_after, flat_base, rise);
}

}  // namespace terracl::test::examples
