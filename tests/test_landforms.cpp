// SPDX-License-Identifier: Apache-2.0
// Landform cross-sections: every profile against its analytic formula, C1 continuity of
// the profile across a bent polyline, tapers, smoothing, and no default feature narrower than 3 cells.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/tensor.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

using namespace terracl;
using json = nlohmann::json;

namespace {

// The potential P of `prims` on a W x H grid (read back from the mask scratch buffer).
std::vector<float> potential(int W, int H, double cell, const std::vector<Primitive>& prims) {
  Device& d = test::device();
  GradientField g(W, H);
  g.georef.cell_x = g.georef.cell_y = cell;
  GradientBuffers b = GradientBuffers::upload(d, g);
  add_profile_gradient(d, b, prims);
  std::vector<float> p(size_t(W) * H);
  d.queue().enqueueReadBuffer(b.mask, CL_TRUE, 0, p.size() * sizeof(float), p.data());
  return p;
}

Primitive line(std::vector<Vec2> pts, double r, Profile prof, double a) {
  Primitive p;
  p.shape = PrimitiveShape::Polyline;
  p.points = std::move(pts);
  p.radius = r;
  p.profile = prof;
  p.profile_amplitude = a;
  return p;
}

}  // namespace

// A straight stroke across the grid: the integrated gradient (the solve's input) equals the
// analytic cross-section P(d) of every profile, cell by cell.
TEST(Landforms, ProfilesMatchTheirAnalyticCrossSection) {
  Device& d = test::device();
  const int W = 9, H = 81;
  const double cell = 2, r = 50, a = 30, y0 = 80.5;  // the line between cell rows
  struct Case {
    Profile p;
    double floor, face, scree;
  };
  for (const Case& c : {Case{Profile::Round, 0, 1, 0}, Case{Profile::Sharp, 0, 1, 0}, Case{Profile::V, 0, 1, 0},
                        Case{Profile::U, 0, 1, 0}, Case{Profile::U, 20, 1, 0}, Case{Profile::Drop, 0, 0.3, 0.35},
                        Case{Profile::Step, 0, 1, 0}}) {
    Primitive pr = line({{-100, y0}, {200, y0}}, r, c.p, a);
    pr.floor_half_width = c.floor;
    pr.face_fraction = c.face;
    pr.scree = c.scree;
    GradientField g(W, H);
    g.georef.cell_x = g.georef.cell_y = cell;
    GradientBuffers b = GradientBuffers::upload(d, g);
    add_profile_gradient(d, b, {pr});
    GradientField out = g;
    b.download(d, out);
    const int x = 4;
    // P at row 0 is the analytic value there (the box starts inside the support for Drop/Step).
    double z = profile_value(c.p, std::abs(0 - y0), 0 - y0 < 0 ? -(y0 - 0) : 0, r, a, c.floor, c.face, c.scree);
    double worst = 0;
    for (int y = 0; y + 1 < H; ++y) {
      z += out.gy[size_t(y) * W + x] * cell;
      const double py = (y + 1) * cell, s = py - y0;  // right of an eastward stroke is south (+y)
      const double want = profile_value(c.p, std::abs(s), s, r, a, c.floor, c.face, c.scree);
      worst = std::max(worst, std::abs(z - want));
    }
    EXPECT_LT(worst, 2e-3 * a) << "profile " << int(c.p) << " floor " << c.floor;
  }
  // Spot values of the formulas themselves.
  EXPECT_NEAR(profile_value(Profile::V, 25, 25, 50, 10), 3.125, 1e-12);         // 10 (1 - 1/2)^3 (1 + 3/2)
  EXPECT_NEAR(profile_value(Profile::U, 25, 25, 50, 10), 10 * std::pow(1 - 1.0 / 16, 2), 1e-12);
  EXPECT_NEAR(profile_value(Profile::U, 10, 10, 50, 10, 20), 10, 1e-12);       // on the flat floor
  EXPECT_NEAR(profile_value(Profile::Drop, 0, 50, 50, 10, 0, 0.3, 0.35), -10, 1e-12);
}

// A bent stroke: the distance to a polyline has a crease along the medial axis inside the bend, so
// a profile of the nearest distance alone has a slope jump there (the seams of the mountain_range
// example). With the two nearest segments blended, the profile is C1: its largest second difference
// shrinks like h^2 when the cell size h halves (a slope jump would only halve it).
TEST(Landforms, ProfileIsC1AcrossABend) {
  auto max_second_diff = [](double cell) {
    const double L = 160;
    const int n = int(std::lround(L / cell)) + 1;
    Primitive p = line({{20, 140}, {80, 40}, {140, 140}}, 45, Profile::Round, 100);  // a sharp bend
    const auto P = potential(n, n, cell, {p});
    double worst = 0, jump = 0;
    for (int y = 1; y + 1 < n; ++y)
      for (int x = 1; x + 1 < n; ++x) {
        const size_t o = size_t(y) * n + x;
        worst = std::max({worst, std::abs(P[o + 1] - 2.0 * P[o] + P[o - 1]), std::abs(P[o + n] - 2.0 * P[o] + P[o - n])});
        jump = std::max({jump, std::abs(double(P[o + 1]) - P[o]), std::abs(double(P[o + n]) - P[o])});
      }
    return std::make_pair(worst, jump);
  };
  const auto [c2, j2] = max_second_diff(2.0);
  const auto [c1, j1] = max_second_diff(1.0);
  // Value: the largest step between neighbours halves with the cell (no jump).
  EXPECT_LT(j1, 0.6 * j2);
  // Slope: the largest second difference drops about 4x (3x allows for float rounding).
  EXPECT_LT(c1, c2 / 3.0) << c2 << " -> " << c1;
}

// A smoothed stroke: the Catmull-Rom spline is sampled in pieces of r/8, and the distance
// to those chords creases on the bisector inside every vertex, a jump of the slope of about the
// pieces' turning angle. With the pieces taken as Hermite curves (Primitive::smooth) the slope is
// continuous along the stroke. Measured on a circular arc (radius 200 m, r = 50 m) half-way down
// its inner flank: the gradient of P at points one cell apart along the stroke (central differences
// at exactly those points: a 3 x 3 grid of that cell centred on each), the largest change between
// neighbours over the largest slope. A continuous slope changes by O(cell): < 1 % and halving with
// the cell; the chords' creases stay at their ~3 % whatever the cell.
TEST(Landforms, SmoothedStrokeSlopeIsContinuousAlongTheStroke) {
  const double Rc = 200, r = 50, a = 100;
  std::vector<Vec2> ctrl;
  for (int i = -2; i <= 2; ++i) ctrl.push_back({Rc * std::cos(i * 0.5), Rc * std::sin(i * 0.5)});
  const std::vector<Vec2> path = catmull_rom(ctrl, r / 8);
  auto worst_jump = [&](double cell, bool smooth) {
    std::vector<std::array<double, 2>> g;
    const double rho = Rc - 0.5 * r;
    for (double phi = -0.17; phi <= 0.17; phi += cell / rho) {
      const double qx = rho * std::cos(phi), qy = rho * std::sin(phi);
      Primitive p = line({}, r, Profile::Round, a);
      for (const auto& v : path) p.points.push_back({v.x - qx + cell, v.y - qy + cell});  // q at cell (1, 1)
      p.smooth = smooth;
      const auto P = potential(3, 3, cell, {p});
      g.push_back({(double(P[5]) - P[3]) / (2 * cell), (double(P[7]) - P[1]) / (2 * cell)});
    }
    double top = 0, jump = 0;
    for (size_t i = 0; i < g.size(); ++i) {
      top = std::max(top, std::hypot(g[i][0], g[i][1]));
      if (i) jump = std::max(jump, std::hypot(g[i][0] - g[i - 1][0], g[i][1] - g[i - 1][1]));
    }
    return jump / top;
  };
  const double j2 = worst_jump(0.5, true), j1 = worst_jump(0.25, true);
  EXPECT_LT(j2, 0.01);
  EXPECT_LT(j1, 0.6 * j2) << j2 << " -> " << j1;
  // The chords alone: the creases (the defect this guards against) do not shrink with the cell.
  const double c2 = worst_jump(0.5, false), c1 = worst_jump(0.25, false);
  std::printf("slope jump along a smoothed stroke: Hermite %.4f -> %.4f, chords %.4f -> %.4f (cell 0.5 -> 0.25 m)\n", j2,
              j1, c2, c1);
  EXPECT_GT(c1, 0.012);
  EXPECT_GT(c1, 0.8 * c2);
}

// A smoothed bend tighter than its half-width: an arc of 330 degrees with a radius of curvature of
// 240 m < r = 350 m and amplitudes changing along it. On the inner side the nearest piece changes from
// cell to cell around the centre, and the chords' creases made a fan of lines converging on it. With
// the Hermite pieces the inner flank is C1: the largest second difference of P drops about 4x when
// the cell halves (a crease would only halve it); the chords' fan fails that. Measured on the inner
// flank of the middle 180 degrees, at 120-230 m from the centre: the centre itself is a cone point
// of the distance to any curve (every piece is as near), the clipping or blending that would round
// it off is not done.
TEST(Landforms, TightSmoothedBendHasNoFan) {
  const double R = 240, cx = 440, cy = 440;
  std::vector<Vec2> ctrl;
  std::vector<double> amp, z;
  for (int i = 0; i <= 11; ++i) {  // -165 .. 165 degrees: the spline's end segments (whose curvature
    const double a = (-165 + 30 * i) * M_PI / 180;  // differs) stay away from the measured part
    ctrl.push_back({cx + R * std::cos(a), cy + R * std::sin(a)});
    amp.push_back(60 + 40 * std::sin(M_PI * i / 11));
  }
  const auto path = catmull_rom(ctrl, 350.0 / 8, amp, &z);
  auto max_second_diff = [&](double cell, bool smooth) {
    const int n = int(std::lround(880 / cell)) + 1;
    Primitive p = line(path, 350, Profile::Round, 1);
    p.amplitude = z;
    p.smooth = smooth;
    const auto P = potential(n, n, cell, {p});
    double worst = 0;
    for (int y = 1; y + 1 < n; ++y)
      for (int x = 1; x + 1 < n; ++x) {
        const double dx = x * cell - cx, dy = y * cell - cy, rho = std::hypot(dx, dy);
        if (rho < 120 || rho > 230 || std::abs(std::atan2(dy, dx)) > M_PI / 2) continue;
        const size_t o = size_t(y) * n + x;
        const double v = std::max(std::abs(P[o + 1] - 2.0 * P[o] + P[o - 1]), std::abs(P[o + n] - 2.0 * P[o] + P[o - n]));
        worst = std::max(worst, v);
      }
    return worst;
  };
  const double s2 = max_second_diff(4, true), s1 = max_second_diff(2, true);
  const double c2 = max_second_diff(4, false), c1 = max_second_diff(2, false);
  std::printf("largest second difference inside a tight bend: Hermite %.4g -> %.4g, chords %.4g -> %.4g (cell 4 -> 2 m)\n",
              s2, s1, c2, c1);
  EXPECT_LT(s1, s2 / 3.0);
  EXPECT_GT(c1, c2 / 3.0);
}

// A hairpin tighter than the half-width (legs 120 m apart, r = 100 m): between the legs the
// distance to the stroke is min(d_leg1, d_leg2), which creases on the midline, and the profile
// P(d) with it (a slope jump, a line in hillshades). The two legs' profiles are blended there
// (the nearest and the runner-up local minimum of the distance along the stroke), so P is C1
// across the midline: its largest second difference across it falls like h^2 (a slope jump: like h).
TEST(Landforms, HairpinHasNoCreaseBetweenItsLegs) {
  const double cy = 300, half = 60, r = 100;
  std::vector<Vec2> ctrl;
  for (double x = 40; x < 400; x += 60) ctrl.push_back({x, cy - half});
  for (int i = 1; i < 6; ++i) {  // the turn: a half circle of radius 60 m around (400, cy)
    const double a = M_PI * i / 6;
    ctrl.push_back({400 + half * std::sin(a), cy - half * std::cos(a)});
  }
  for (double x = 400; x > 39; x -= 60) ctrl.push_back({x, cy + half});
  const auto path = catmull_rom(ctrl, r / 8);
  auto crease = [&](double cell) {
    const int n = int(std::lround(600 / cell)) + 1;
    Primitive p = line(path, r, Profile::Round, 100);
    p.smooth = true;
    const auto P = potential(n, n, cell, {p});
    double worst = 0;
    const int yc = int(std::lround(cy / cell));
    for (int x = int(120 / cell); x <= int(320 / cell); ++x)
      for (int y = yc - 2; y <= yc + 2; ++y) {
        const size_t o = size_t(y) * n + x;
        worst = std::max(worst, double(std::abs(P[o + n] - 2.0f * P[o] + P[o - n])));
      }
    return worst;
  };
  const double c4 = crease(4), c2 = crease(2), c1 = crease(1);
  std::printf("largest second difference across a hairpin's midline: %.4g, %.4g, %.4g (cell 4, 2, 1 m)\n", c4, c2, c1);
  EXPECT_LT(c2, c4 / 3.0);
  EXPECT_LT(c1, c2 / 3.0);
}

// Stroke ends taper: with a taper the profile fades to zero at the end points (no round cap, no
// knob); without one the end is a full-height cap.
TEST(Landforms, StrokeEndsTaper) {
  Primitive p = line({{40, 100}, {160, 100}}, 30, Profile::Round, 50);
  const auto cap = potential(201, 201, 1, {p});
  p.taper_start = p.taper_end = 30;
  const auto tap = potential(201, 201, 1, {p});
  const size_t end = size_t(100) * 201 + 40, mid = size_t(100) * 201 + 100, beyond = size_t(100) * 201 + 30;
  EXPECT_NEAR(cap[end], 50, 1e-3);
  EXPECT_NEAR(tap[mid], 50, 1e-3);
  EXPECT_NEAR(tap[end], 0, 1e-3);
  EXPECT_NEAR(tap[beyond], 0, 1e-3);
  EXPECT_GT(cap[beyond], 10);
}

TEST(Landforms, CatmullRomPassesThroughThePointsWithoutKinks) {
  const std::vector<Vec2> pts = {{0, 0}, {100, 0}, {150, 80}, {300, 90}};
  std::vector<double> z;
  const auto s = catmull_rom(pts, 5, {1, 2, 3, 4}, &z);
  ASSERT_EQ(s.size(), z.size());
  for (const auto& p : pts) {
    double best = 1e9;
    for (const auto& q : s) best = std::min(best, std::hypot(q.x - p.x, q.y - p.y));
    EXPECT_LT(best, 1e-9);
  }
  // Turning angle between consecutive pieces stays small (the input turns by ~58 degrees at once).
  double worst = 0;
  for (size_t i = 1; i + 1 < s.size(); ++i) {
    const double a1 = std::atan2(s[i].y - s[i - 1].y, s[i].x - s[i - 1].x);
    const double a2 = std::atan2(s[i + 1].y - s[i].y, s[i + 1].x - s[i].x);
    worst = std::max(worst, std::abs(std::remainder(a2 - a1, 2 * M_PI)));
  }
  EXPECT_LT(worst, 0.25);
  EXPECT_NEAR(z.front(), 1, 1e-12);
  EXPECT_NEAR(z.back(), 4, 1e-12);
}

// Every curve tool at its default width on 10, 30 and 90 m cells: the feature's width at half its
// relief (the 10-90 % transition for cliffs and faults) is at least 3 cells.
TEST(Landforms, NoDefaultFeatureIsNarrowerThanThreeCells) {
  const int N = 97;
  for (double cell : {10.0, 30.0, 90.0}) {
    const json P = json::array({json::array({-20, 48}), json::array({116, 48})});  // cells, past the grid
    const std::vector<std::pair<std::string, json>> ops = {
        {"crest", {{"op", "crest"}, {"points", P}, {"elevation", 200}}},
        {"free_crest", {{"op", "free_crest"}, {"points", P}, {"height", 150}}},
        {"ravine", {{"op", "ravine"}, {"points", P}, {"depth", 80}}},
        {"river", {{"op", "river"}, {"points", P}, {"elevation", 0}}},
        {"mountain_range", {{"op", "mountain_range"}, {"points", P}, {"height", 400}, {"roughness", 0}}},
        {"cliff", {{"op", "cliff"}, {"points", P}, {"elevation", 0}, {"height", 100}}},
        {"fault", {{"op", "fault"}, {"points", P}, {"throw", 60}}}};
    for (const auto& [name, op] : ops) {
      EditSession s(test::device(), *parse_flat_spec(fmt::format("flat:{}x{}@{}", N, N, cell)));
      s.apply(json{{"units", "cells"}, {"operations", json::array({op})}});
      const Heightfield& h = s.height();
      std::vector<double> col;
      for (int y = 0; y < N; ++y) col.push_back(h.at(N / 2, y));
      double width = 0;
      if (name == "cliff" || name == "fault") {
        const double a = col.front(), b = col.back();
        int y10 = -1, y90 = -1;
        for (int y = 0; y < N; ++y) {
          const double f = (col[y] - a) / (b - a);
          if (y10 < 0 && f >= 0.1) y10 = y;
          if (y90 < 0 && f >= 0.9) y90 = y;
        }
        width = y90 - y10;
      } else {
        const double base = 0.5 * (col.front() + col.back());
        double peak = 0;
        for (double v : col) peak = std::max(peak, std::abs(v - base));
        ASSERT_GT(peak, 1.0) << name;
        for (double v : col) width += std::abs(v - base) >= 0.5 * peak ? 1 : 0;
      }
      EXPECT_GE(width, 3) << name << " at " << cell << " m cells";
    }
  }
}

// A ravine deepens downstream and cuts through a constrained rim it crosses.
// A cliff (the gallery's cliff band): a steep face over a concave scree apron that starts
// at the face's foot with the face's slope there (no ledge, no kink) and flattens towards its toe,
// so the apron reads as a band of its own: (1 - face) r wide, every cell of it steeper than a
// tenth of its top slope except near the toe. The former profile (two smoothersteps) ended the face
// with zero slope and spread the scree over the whole r, under the face.
TEST(Landforms, CliffFaceMeetsAConcaveScreeApron) {
  const int W = 5, H = 161;
  const double r = 120, a = 100, c = 0.3, k = 0.4;  // 1 m cells: the face is 36 cells, the apron 84
  Primitive p = line({{-50, 20.5}, {60, 20.5}}, r, Profile::Drop, a);
  p.face_fraction = c;
  p.scree = k;
  const auto P = potential(W, H, 1, {p});
  std::vector<double> slope;  // -dP/dy between rows y and y + 1, south of the top edge (row 21 on)
  for (int y = 21; y + 1 < H; ++y) slope.push_back(P[size_t(y) * W] - P[size_t(y + 1) * W]);
  const int foot = int(c * r);  // the face's foot: slope index foot - 1 .. foot
  const double top = 2 * k * a / ((1 - c) * r);  // the apron's slope at its top (analytic)
  EXPECT_NEAR(slope[foot], top, 0.03 * top);
  EXPECT_LT(std::abs(slope[foot] - slope[foot - 1]), 0.03 * top) << "a slope jump at the foot of the face";
  double face_max = 0;
  for (int i = 0; i < foot; ++i) face_max = std::max(face_max, slope[i]);
  EXPECT_GT(face_max, 2.5 * top) << "the face is not steeper than the apron";
  int band = 0;
  for (int i = foot; i < int(r) - 1; ++i) {
    EXPECT_LE(slope[i + 1], slope[i] + 1e-4) << "the apron is not concave at " << i;
    band += slope[i] > 0.1 * top;
  }
  EXPECT_GE(band, int(0.85 * (1 - c) * r));
  EXPECT_NEAR(P[size_t(21 + int(r)) * W], -a, 1e-3);  // the whole drop at r
}

TEST(Landforms, RavineDeepensDownstreamAndCutsTheRim) {
  auto run = [](bool cut) {
    EditSession s(test::device(), *parse_flat_spec("flat:97x97@10"));
    s.apply(json{{"units", "cells"},
                 {"operations",
                  {{{"op", "cliff"}, {"points", {{-10, 40}, {110, 40}}}, {"elevation", 100}, {"height", 80}},
                   {{"op", "ravine"}, {"points", {{48, 5}, {48, 90}}}, {"depth", 60}, {"width", 200}, {"cut_rims", cut}}}}});
    return s.height();
  };
  const Heightfield cut = run(true), kept = run(false);
  EXPECT_NEAR(kept.at(48, 40), 100, 1e-3);        // the rim holds its elevation
  EXPECT_LT(cut.at(48, 40), 100 - 10);           // the ravine notches it
  // Deeper downstream: the ravine's depth below its banks grows along the stroke.
  const Heightfield flat_only = [] {
    EditSession s(test::device(), *parse_flat_spec("flat:97x97@10"));
    s.apply(json{{"units", "cells"}, {"operations", {{{"op", "ravine"}, {"points", {{48, -10}, {48, 106}}}, {"depth", 60}}}}});
    return s.height();
  }();
  const double up = flat_only.at(20, 15) - flat_only.at(48, 15), down = flat_only.at(20, 80) - flat_only.at(48, 80);
  EXPECT_GT(down, 1.5 * up);
}

// A gradient-only ravine that ends on a slope used to close in a bowl of radius r: its floor rose
// by the whole depth over r, a pit wherever the ground fell less (the blue holes at the ravine
// ends of the gallery). It now exits: the stroke runs on past its last point along its tangent for
// `exit` [3 r], its depth fading to zero there. Along the axis, the deepest closed depression (the
// barrier downstream minus the floor) on a 0.2 ramp shrinks at least 4x and below 15 % of the depth.
TEST(Landforms, RavineExitsWithoutAPitAtItsOpenEnd) {
  const int W = 97, H = 161;
  Heightfield ramp(W, H);
  ramp.georef.cell_x = ramp.georef.cell_y = 10;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) ramp.at(x, y) = float(0.2 * 10 * (H - 1 - y));  // falls southwards
  auto pit = [&](const json& exit) {
    json op{{"op", "ravine"}, {"points", {{48, 10}, {48, 70}}}, {"depth", 40}, {"width", 20}};
    if (!exit.is_null()) op["exit"] = exit;
    EditSession s(test::device(), ramp, EditOptions{});
    s.apply(json{{"units", "cells"}, {"solve", "global"}, {"operations", {op}}});
    const Heightfield& h = s.height();
    double worst = 0, barrier = -1e30;
    for (int y = H - 1; y >= 0; --y) {  // from the outlet upstream
      worst = std::max(worst, barrier - double(h.at(48, y)));
      barrier = std::max(barrier, double(h.at(48, y)));
    }
    return worst;
  };
  const double bowl = pit(0), exits = pit(nullptr);
  std::printf("ravine end on a 0.2 ramp: a pit of %.2f m with a round end, %.2f m exiting\n", bowl, exits);
  EXPECT_GT(bowl, 15.0) << "the round end should pit (the defect this guards)";
  EXPECT_LT(exits, 0.15 * 40);
  EXPECT_LT(4 * exits, bowl);
}

// A crest without `height` takes its default flank height from the terrain under it: read from the
// last solution, without a solve of its own (issue 12: 50 ms per crest in `bench edit`, 768 ms
// for a studio replay of 30). Its constrained line still reaches its elevation.
TEST(Landforms, CrestWithoutHeightDoesNotSolve) {
  EditSession s(test::device(), *parse_flat_spec("flat:97x97@10"));
  s.apply(json{{"units", "cells"}, {"operations", {{{"op", "noise"}, {"amplitude", 20}, {"wavelength", 30}}}}});
  s.solve(false);
  ASSERT_EQ(s.report()["solves"], 1);
  for (int i = 0; i < 3; ++i)
    s.apply(json{{"units", "cells"},
                 {"operations", {{{"op", "crest"}, {"points", {{20, 10 + 38 * i}, {76, 10 + 38 * i}}}, {"elevation", 300}}}}});
  EXPECT_EQ(s.report()["solves"], 1) << "a crest without height solved to read the terrain";
  EXPECT_NEAR(s.height().at(48, 48), 300, 1e-3);
  EXPECT_GT(300 - s.height().at(48, 48 + 8), 30) << "no flanks";
}

TEST(Landforms, MesaCapHasDetailAndTalusFlanks) {
  EditSession s(test::device(), *parse_flat_spec("flat:97x97@10"));
  s.apply(json{{"units", "cells"},
               {"operations", {{{"op", "mesa"}, {"center", {48, 48}}, {"radius", 25}, {"elevation", 300}, {"height", 200}}}}});
  const Heightfield& h = s.height();
  double lo = 1e9, hi = -1e9;
  for (int y = 38; y <= 58; ++y)
    for (int x = 38; x <= 58; ++x) lo = std::min(lo, double(h.at(x, y))), hi = std::max(hi, double(h.at(x, y)));
  EXPECT_GT(hi - lo, 1.0) << "the cap is a flat disc";
  EXPECT_LT(hi - lo, 0.2 * 200);
  EXPECT_NEAR(h.at(48 + 25, 48), 300, 1e-3);  // the rim is hard
}

TEST(Landforms, OldWidthWithRadiusIsAClearError) {
  EditSession s(test::device(), *parse_flat_spec("flat:33x33@10"));
  try {
    s.apply(json{{"units", "cells"},
                 {"operations", {{{"op", "crest"}, {"points", {{2, 2}, {30, 30}}}, {"elevation", 50}, {"radius", 5}, {"width", 2}}}}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/operations/0/width"), std::string::npos) << m;
    EXPECT_NE(m.find("floor"), std::string::npos) << m;
  }
}
