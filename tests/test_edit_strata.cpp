// SPDX-License-Identifier: Apache-2.0
// The "strata" edit operation: layered rock turns a steep ramp into a staircase whose
// risers and treads lie at the layer boundaries, leaves gentle ground and the outside of its
// region untouched, and rejects bad layers with the JSON path.
#include "edit_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace terracl;
using json = nlohmann::json;

namespace {

// A ramp of slope 1 (45 degrees) along x from x = 20 (0 m) to x = 220 (200 m), flat beyond, on 1 m cells.
Heightfield ramp_base() {
  Heightfield h(240, 16);
  h.georef.cell_x = h.georef.cell_y = 1;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) h.at(x, y) = float(std::clamp(x - 20, 0, 200));
  return h;
}

// The analytic staircase of a stack without jitter: pairs of `hard` over `soft` metres from `top`
// down to `bottom`, the identity at each pair's boundaries.
double staircase(double z, double top, double bottom, double hard, double soft, double contrast) {
  const double P = hard + soft, fs = (soft + hard / contrast) / P, fh = contrast * fs;
  for (double hi = top; hi - P >= bottom; hi -= P) {
    const double lo = hi - P;
    if (z < lo || z > hi) continue;
    const double split = lo + soft / fs;
    return z <= split ? lo + fs * (z - lo) : lo + soft + fh * (z - split);
  }
  return z;
}

json strata_op() {
  return {{"op", "strata"},   {"polygon", {{-10, -10}, {250, -10}, {250, 26}, {-10, 26}}},
          {"top", 170},       {"bottom", 30},
          {"thickness", 20},  {"soft_thickness", 10},
          {"jitter", 0},      {"contrast", 6}};
}

std::string message(const json& op) { return test::edit_op_error(ramp_base(), op); }

}  // namespace

TEST(EditStrata, RampBecomesStaircaseAtTheLayerBoundaries) {
  const Heightfield base = ramp_base();
  EditSession s(test::device(), base);
  s.apply({{"operations", {strata_op()}}});
  const Heightfield& h = s.height();
  ASSERT_EQ(s.log()[0]["layer_pairs"], 4);  // 170-140, 140-110, 110-80, 80-50
  double worst = 0;
  for (int x = 0; x < h.width; ++x) {
    const double want = staircase(base.at(x, 8), 170, 30, 20, 10, 6);
    worst = std::max(worst, std::abs(h.at(x, 8) - want));
  }
  EXPECT_LT(worst, 0.05) << "the reconstruction is the analytic staircase S(h)";
  // Risers (faces steeper than 2, the hard layers' slope is 2.67) span exactly the hard layers'
  // elevations [lo + 10, lo + 30] of each pair, treads (slope 0.44) the soft ones.
  for (double lo : {50.0, 80.0, 110.0, 140.0}) {
    double rlo = 1e9, rhi = -1e9;
    int treads = 0;
    for (int x = 0; x + 1 < h.width; ++x) {
      const double a = h.at(x, 8), b = h.at(x + 1, 8), s1 = b - a;
      if (s1 > 2 && a >= lo - 1 && b <= lo + 31) rlo = std::min(rlo, a), rhi = std::max(rhi, b);
      if (s1 > 0.3 && s1 < 0.6 && a >= lo && b <= lo + 10.5) ++treads;
    }
    EXPECT_NEAR(rlo, lo + 10, 1.5) << "riser foot of the pair at " << lo;
    EXPECT_NEAR(rhi, lo + 30, 1.5) << "riser top of the pair at " << lo;
    EXPECT_GE(treads, 20) << "a bench ~22 m wide under the riser of the pair at " << lo;
  }
  // Outside the stack (below 50 m, above 170 m) the ramp is unchanged.
  EXPECT_NEAR(h.at(40, 8), 20.0, 0.05);
  EXPECT_NEAR(h.at(205, 8), 185.0, 0.05);
}

// Dipping beds: with "dip" 20 degrees towards the south (dip_direction -90: counter-clockwise from
// east), the beds at row y sit tan(20) y metres lower, so on the ramp every row is the staircase
// read at h + tan(20) y and shifted back: S(h - o) + o, o = -tan(20) y. The risers move down the
// ramp from row to row (the bands cross the ramp's contours).
TEST(EditStrata, DippingBedsAreTheStaircaseShiftedPerRow) {
  const Heightfield base = ramp_base();
  json op = strata_op();
  op["dip"] = 20;
  op["dip_direction"] = -90;
  EditSession s(test::device(), base);
  s.apply({{"operations", {op}}});
  const Heightfield& h = s.height();
  const double t = std::tan(20 * M_PI / 180);
  double worst = 0, shift = 0;
  for (int y = 3; y <= 12; ++y)
    for (int x = 0; x < h.width; ++x) {
      const double o = -t * y;
      const double want = staircase(base.at(x, y) - o, 170, 30, 20, 10, 6) + o;
      worst = std::max(worst, std::abs(h.at(x, y) - want));
      shift = std::max(shift, double(std::abs(h.at(x, y) - h.at(x, 3))));
    }
  EXPECT_LT(worst, 0.1) << "each row is the staircase of beds offset by -tan(dip) y";
  EXPECT_GT(shift, 5.0) << "the rows differ: the bands are not level";
  // Undulating beds move the bands too, and a level stack (dip 0, undulation 0) is the former one.
  op.erase("dip"), op.erase("dip_direction");
  op["undulation"] = 4;
  op["undulation_wavelength"] = 40;
  EditSession u(test::device(), base), l(test::device(), base);
  u.apply({{"operations", {op}}});
  op["undulation"] = 0;
  l.apply({{"operations", {op}}});
  EditSession plain(test::device(), base);
  plain.apply({{"operations", {strata_op()}}});
  EXPECT_EQ(l.height().z, plain.height().z);
  double moved = 0;
  for (size_t i = 0; i < base.z.size(); ++i) moved = std::max(moved, double(std::abs(u.height().z[i] - plain.height().z[i])));
  EXPECT_GT(moved, 1.0);
}

TEST(EditStrata, GradientFormMatchesTheRemapWhereBothApplyFully) {
  const Heightfield base = ramp_base();
  json op = strata_op();
  op["jitter"] = 0.4;  // a jittered stack: both forms read the same layers
  EditSession a(test::device(), base), b(test::device(), base);
  a.apply({{"operations", {op}}});
  op["form"] = "remap";
  b.apply({{"operations", {op}}});
  const Heightfield &ha = a.height(), &hb = b.height();
  double worst = 0, moved = 0;
  for (int x = 0; x < base.width; ++x) {
    worst = std::max(worst, double(std::abs(ha.at(x, 8) - hb.at(x, 8))));
    moved = std::max(moved, double(std::abs(ha.at(x, 8) - base.at(x, 8))));
  }
  EXPECT_LT(worst, 0.05);
  EXPECT_GT(moved, 3.0);
}

TEST(EditStrata, GentleGroundIsUntouchedBitForBit) {
  // Slopes of at most 18 degrees everywhere (below min_slope 20): nothing changes, not one bit.
  const Heightfield base = test::smooth_terrain(96, 80, 10.0, 8.0, 3);
  double steepest = 0;
  for (int y = 0; y + 1 < base.height; ++y)
    for (int x = 0; x + 1 < base.width; ++x)
      steepest = std::max({steepest, std::abs(base.at(x + 1, y) - base.at(x, y)) / 10.0, std::abs(base.at(x, y + 1) - base.at(x, y)) / 10.0});
  ASSERT_LT(steepest, std::tan(18 * M_PI / 180)) << "the base is gentle";
  ASSERT_GT(steepest, 0.02);
  EditSession s(test::device(), base);
  json op = {{"op", "strata"}, {"center", {480, 400}}, {"radius", 300}, {"falloff", 50}, {"top", 200}, {"thickness", 8}};
  s.apply({{"operations", {op}}});
  EXPECT_EQ(s.log()[0]["faces"], 0);
  EXPECT_EQ(test::bit_differences(s.height(), base), 0u);
  // On the ramp base the flat parts keep their gradient bit for bit next to the changed ramp.
  const Heightfield ramp = ramp_base();
  EditSession r0(test::device(), ramp), r1(test::device(), ramp);
  json wide = strata_op();
  wide.erase("bottom");
  wide["top"] = 199;
  r1.apply({{"operations", {wide}}});
  const GradientField g0 = r0.gradient(), g1 = r1.gradient();
  size_t flat = 0, differ = 0, steep_changed = 0;
  for (int y = 0; y < ramp.height; ++y)
    for (int x = 0; x + 1 < ramp.width; ++x) {
      const size_t i = size_t(y) * ramp.width + x;
      if (ramp.at(x + 1, y) == ramp.at(x, y)) {
        ++flat;
        differ += g0.gx[i] != g1.gx[i] || g0.gy[i] != g1.gy[i];
      } else {
        steep_changed += g0.gx[i] != g1.gx[i];
      }
    }
  EXPECT_GT(flat, 500u);
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(steep_changed, 1000u);
}

TEST(EditStrata, OutsideTheRegionIsUnchanged) {
  // A 45-degree plane x; a disc of layers in its middle. Faces beyond the disc and its soft edge
  // keep their bits; cells beyond the local solve's falloff (3 x the reach of 30 m) keep theirs.
  Heightfield base(320, 320);
  base.georef.cell_x = base.georef.cell_y = 1;
  for (int y = 0; y < 320; ++y)
    for (int x = 0; x < 320; ++x) base.at(x, y) = float(x);
  EditSession s0(test::device(), base), s(test::device(), base);
  json op = {{"op", "strata"}, {"center", {160, 160}}, {"radius", 30}, {"falloff", 10}, {"top", 250}, {"thickness", 12}};
  s.apply({{"operations", {op}}});
  ASSERT_TRUE(s.local());
  const GradientField g0 = s0.gradient(), g = s.gradient();
  const Heightfield& h = s.height();
  size_t face_out = 0, cell_out = 0;
  double inside = 0;
  for (int y = 0; y < 320; ++y)
    for (int x = 0; x < 320; ++x) {
      const size_t i = size_t(y) * 320 + x;
      const double d = std::hypot(x - 160.0, y - 160.0);
      if (d > 42) face_out += g0.gx[i] != g.gx[i] || g0.gy[i] != g.gy[i];
      if (d > 40 + 3 * 30 + 2) cell_out += h.at(x, y) != base.at(x, y);
      if (d < 25) inside = std::max(inside, double(std::abs(h.at(x, y) - base.at(x, y))));
    }
  EXPECT_EQ(face_out, 0u);
  EXPECT_EQ(cell_out, 0u);
  EXPECT_GT(inside, 2.0) << "the layers did change the plane inside the disc";
}

TEST(EditStrata, BadInputNamesTheJsonPath) {
  json op = strata_op();
  EXPECT_EQ(message(op), "");
  op["thickness"] = -5;
  EXPECT_NE(message(op).find("/operations/0/thickness"), std::string::npos) << message(op);
  op = strata_op();
  op["soft_thickness"] = 0;
  EXPECT_NE(message(op).find("/operations/0/soft_thickness"), std::string::npos);
  op = strata_op();
  op["polygon"] = {{10, 10}, {20, 10}, {30, 10}};  // collinear: no area
  EXPECT_NE(message(op).find("/operations/0/polygon: the polygon encloses no area"), std::string::npos) << message(op);
  op = strata_op();
  op.erase("polygon");
  EXPECT_NE(message(op).find("/operations/0: needs a region"), std::string::npos);
  op["center"] = {10, 10};
  op["radius"] = 0;
  EXPECT_NE(message(op).find("/operations/0/radius"), std::string::npos);
  op = strata_op();
  op["bottom"] = 300;
  EXPECT_NE(message(op).find("/operations/0/bottom"), std::string::npos);
  op = strata_op();
  op.erase("top");
  EXPECT_NE(message(op).find("/operations/0/top"), std::string::npos);
  op = strata_op();
  op["contrast"] = 0.5;
  EXPECT_NE(message(op).find("/operations/0/contrast"), std::string::npos);
  EXPECT_NE(message({{"op", "strata"}, {"polygon", {{0, 0}, {100, 0}, {100, 10}}}, {"top", 100}, {"thickness", 10}, {"dip", 60}}).find("/operations/0/dip"), std::string::npos);
  EXPECT_NE(message({{"op", "strata"}, {"polygon", {{0, 0}, {100, 0}, {100, 10}}}, {"top", 100}, {"thickness", 10}, {"undulation", -2}}).find("/operations/0/undulation"), std::string::npos);
}
