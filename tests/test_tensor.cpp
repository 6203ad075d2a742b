// SPDX-License-Identifier: Apache-2.0
// Tensor fields (kernels/tensor.cl) against analytic answers.
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/tensor.hpp>

#include <cmath>
#include <random>

using namespace terracl;

namespace {

GradientField constant_field(int w, int h, double cell, double gx, double gy) {
  GradientField g(w, h);
  g.georef.cell_x = g.georef.cell_y = cell;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t o = size_t(y) * w + x;
      g.gx[o] = x < w - 1 ? float(gx) : 0.f;
      g.gy[o] = y < h - 1 ? float(gy) : 0.f;
    }
  return g;
}

Primitive covering_polygon(int w, int h, double cell) {
  Primitive p;
  p.shape = PrimitiveShape::Polygon;
  p.points = {{-2 * cell, -2 * cell}, {(w + 2) * cell, -2 * cell}, {(w + 2) * cell, (h + 2) * cell}, {-2 * cell, (h + 2) * cell}};
  p.radius = cell;
  return p;
}

GradientField apply(const GradientField& in, const std::vector<Primitive>& prims) {
  Device& d = test::device();
  GradientBuffers b = GradientBuffers::upload(d, in);
  apply_tensor_field(d, b, prims);
  GradientField out = in;
  b.download(d, out);
  return out;
}

}  // namespace

// Figure 6: the angle response of D(60 deg, mu) for gradients of every direction.
TEST(Tensor, DirectionalAngleResponseMatchesAnalytic) {
  const double theta = 60 * M_PI / 180;
  for (double mu : {0.9, 0.5}) {
    Primitive p = covering_polygon(6, 6, 10);
    p.tensor = TensorKind::Directional;
    p.strength = mu;
    p.angle = theta;
    double max_err = 0;
    for (int k = 0; k < 72; ++k) {
      const double phi = k * 5 * M_PI / 180;
      const GradientField out = apply(constant_field(6, 6, 10, std::cos(phi), std::sin(phi)), {p});
      const size_t o = 2 * 6 + 2;
      const double got = std::atan2(out.gy[o], out.gx[o]);
      // D g = g + mu R(2 theta) g, and R(2 theta) rotates the direction phi to 2 theta - phi.
      const double want = std::atan2(std::sin(phi) + mu * std::sin(2 * theta - phi), std::cos(phi) + mu * std::cos(2 * theta - phi));
      max_err = std::max(max_err, std::abs(std::remainder(got - want, 2 * M_PI)));
      // The response drags every direction towards the axis theta (mod pi).
      const double before = std::abs(std::remainder(phi - theta, M_PI)), after = std::abs(std::remainder(got - theta, M_PI));
      EXPECT_LE(after, before + 1e-5) << "phi " << phi;
    }
    EXPECT_LT(max_err, 1e-4) << "mu " << mu;
  }
}

TEST(Tensor, AlphaIsC2CompactAndOneAtZero) {
  EXPECT_DOUBLE_EQ(alpha(0), 1.0);
  EXPECT_DOUBLE_EQ(alpha(1), 0.0);
  for (double t : {1.0, 1.2, 5.0, 1e6}) EXPECT_EQ(alpha(t), 0.0);
  const double e = 1e-4;
  auto d1 = [&](double t) { return (alpha(t + e) - alpha(t - e)) / (2 * e); };
  auto d2 = [&](double t) { return (alpha(t + e) - 2 * alpha(t) + alpha(t - e)) / (e * e); };
  // At 0 (as a function of distance, alpha(|t|)): slope 0, same curvature on both sides.
  EXPECT_NEAR(d1(0), 0.0, 1e-6);
  EXPECT_NEAR(d2(e), d2(-e), 1e-3);
  // At 1: value, slope and curvature all meet the zero function outside.
  EXPECT_NEAR(d1(1 - 2 * e), 0.0, 1e-5);
  EXPECT_NEAR(d2(1 - 2 * e), 0.0, 1e-2);
  EXPECT_NEAR(d2(1 + 2 * e), 0.0, 1e-12);
}

TEST(Tensor, KernelWeightEqualsHostAlpha) {
  Device& d = test::device();
  GradientField g(41, 41);
  g.georef.cell_x = g.georef.cell_y = 2;
  GradientBuffers b = GradientBuffers::upload(d, g);
  Primitive p;
  p.shape = PrimitiveShape::Point;
  p.points = {{40.0, 40.0}};
  p.radius = 25;
  primitive_weight(d, b, {p}, full_box(41, 41), false);
  std::vector<float> w(g.size());
  d.queue().enqueueReadBuffer(b.mask, CL_TRUE, 0, w.size() * 4, w.data());
  for (int y = 0; y < 41; ++y)
    for (int x = 0; x < 41; ++x) {
      const double dist = std::hypot(x * 2 - 40.0, y * 2 - 40.0);
      EXPECT_NEAR(w[size_t(y) * 41 + x], alpha(dist / 25), 1e-5);
    }
}

TEST(Tensor, FieldIsIdentityOutsideEverySupport) {
  const int n = 48;
  GradientField g(n, n);
  g.georef.cell_x = g.georef.cell_y = 5;
  std::mt19937 rng(3);
  std::normal_distribution<float> nd(0, 0.3f);
  for (size_t i = 0; i < g.size(); ++i) g.gx[i] = nd(rng), g.gy[i] = nd(rng);
  Primitive a;
  a.shape = PrimitiveShape::Polyline;
  a.points = {{50, 60}, {120, 90}, {160, 200}};
  a.radius = 30;
  a.strength = 0.8;
  a.tensor = TensorKind::Tangent;
  Primitive b;
  b.shape = PrimitiveShape::Disc;
  b.points = {{180, 60}};
  b.disc_radius = 10;
  b.radius = 20;
  b.strength = 0.7;
  b.angle = 1.0;
  const GradientField out = apply(g, {a, b});
  auto seg_dist = [](double px, double py, Vec2 u, Vec2 v) {
    const double ux = v.x - u.x, uy = v.y - u.y;
    const double t = std::clamp(((px - u.x) * ux + (py - u.y) * uy) / (ux * ux + uy * uy), 0.0, 1.0);
    return std::hypot(px - u.x - t * ux, py - u.y - t * uy);
  };
  int outside = 0, changed_inside = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const size_t o = size_t(y) * n + x;
      const double px = (x + 0.5) * 5, py = y * 5.0;  // the x face centre
      const double da = std::min(seg_dist(px, py, a.points[0], a.points[1]), seg_dist(px, py, a.points[1], a.points[2]));
      const double db = std::max(0.0, std::hypot(px - 180, py - 60) - 10);
      if (da > 30.01 && db > 20.01) {
        ++outside;
        EXPECT_EQ(out.gx[o], g.gx[o]) << x << "," << y;
      } else if (da < 15 && out.gx[o] != g.gx[o]) {
        ++changed_inside;
      }
    }
  EXPECT_GT(outside, 500);
  EXPECT_GT(changed_inside, 50);
}

TEST(Tensor, ScaleTensorMultipliesSlopesInsideDisc) {
  Primitive p;
  p.shape = PrimitiveShape::Disc;
  p.points = {{50, 50}};
  p.disc_radius = 20;
  p.radius = 10;
  p.tensor = TensorKind::Scale;
  p.strength = 1.5;  // factor 2.5
  const GradientField out = apply(constant_field(21, 21, 5, 0.2, -0.1), {p});
  const size_t c = 10 * 21 + 10;
  EXPECT_NEAR(out.gx[c], 0.5, 1e-6);
  EXPECT_NEAR(out.gy[c], -0.25, 1e-6);
}

TEST(Tensor, StepProfileIntegratesToTheThrow) {
  Device& d = test::device();
  GradientField g(60, 20);
  g.georef.cell_x = g.georef.cell_y = 4;
  GradientBuffers b = GradientBuffers::upload(d, g);
  Primitive f;
  f.shape = PrimitiveShape::Polyline;
  f.points = {{120, -200}, {120, 300}};  // vertical line through x = 30 cells, past the grid
  f.radius = 40;
  f.profile = Profile::Step;
  f.profile_amplitude = 25;
  add_profile_gradient(d, b, {f});
  GradientField out = g;
  b.download(d, out);
  for (int y : {0, 10, 19}) {
    double sum = 0;
    for (int x = 0; x < 59; ++x) sum += out.gx[size_t(y) * 60 + x] * 4;
    EXPECT_NEAR(std::abs(sum), 25.0, 1e-3) << "row " << y;
  }
}

TEST(Tensor, BadPrimitiveIsAnError) {
  Primitive p;
  p.shape = PrimitiveShape::Polyline;
  p.points = {{1, 1}};
  p.radius = 3;
  EXPECT_THROW(apply(constant_field(8, 8, 1, 1, 0), {p}), Error);
}

// Profiles are added as the discrete gradient of a potential: curl-free to rounding, so the solve
// reproduces the profile exactly, and a crest's relief equals its height.
TEST(Tensor, ProfileGradientIsCurlFreeWithTheRightRelief) {
  Device& d = test::device();
  GradientField g(50, 40);
  g.georef.cell_x = 3;
  g.georef.cell_y = 4;
  GradientBuffers b = GradientBuffers::upload(d, g);
  Primitive c;
  c.shape = PrimitiveShape::Polyline;
  c.points = {{15, 30}, {60, 90}, {130, 70}};
  c.amplitude = {1.0, 2.0, 1.5};
  c.radius = 35;
  c.profile = Profile::Sharp;
  c.profile_amplitude = 20;
  add_profile_gradient(d, b, {c});
  GradientField out = g;
  b.download(d, out);
  double curl = 0, steep = 0;
  for (int y = 0; y + 1 < 40; ++y)
    for (int x = 0; x + 1 < 50; ++x) {
      const size_t o = size_t(y) * 50 + x;
      curl = std::max(curl, std::abs((out.gx[o + 50] - out.gx[o]) / 4.0 - (out.gy[o + 1] - out.gy[o]) / 3.0));
      steep = std::max(steep, double(std::abs(out.gx[o])));
    }
  EXPECT_GT(steep, 0.5);
  EXPECT_LT(curl, 1e-5 * steep);
  // Integrating gx from the west edge (P = 0 there) to cell (20, 22) at (60 m, 88 m): 1.2 m off the
  // first segment at t = 5505/5625 along it and 1.923 m off the second at t = 40/5300. The amplitude
  // is the cubic Hermite interpolant in arc length (segments 75 m and 72.8 m) with central-difference
  // slopes at inner vertices and the chord's slope at the ends. The two distances are within the
  // blend band b = r/4: the profile values blend, P = (1 - w1) P(d0, a0) + w1 P(d1, a1) with
  // w1 = (1 - smootherstep(g / b)) / 2, g = sqrt(d1^2 + b^2) - sqrt(d0^2 + b^2), and
  // P(d, a) = 20 a (1 - (sqrt(d^2 + rho^2) - rho) / 35)^3, rho = 0.08 r (the sharp crest, rounded).
  const double d0 = 1.2, d1 = std::hypot(60 + 70 * 40.0 / 5300 - 60, 90 - 20 * 40.0 / 5300 - 88);
  const double bw = 35 / 4.0, u = (std::sqrt(d1 * d1 + bw * bw) - std::sqrt(d0 * d0 + bw * bw)) / bw;
  const double w1 = 0.5 * (1 - u * u * u * (u * (u * 6 - 15) + 10));
  auto hermite = [](double a, double b, double ma, double mb, double t) {
    return (2 * t * t * t - 3 * t * t + 1) * a + (t * t * t - 2 * t * t + t) * ma + (3 * t * t - 2 * t * t * t) * b +
           (t * t * t - t * t) * mb;
  };
  const double l0 = 75, l1 = std::hypot(70.0, 20.0);
  const double a0 = hermite(1, 2, 1, l0 * 0.5 / (l0 + l1), 5505.0 / 5625);
  const double a1 = hermite(2, 1.5, l1 * 0.5 / (l0 + l1), -0.5, 40.0 / 5300);
  auto sharp = [](double d) {
    const double rho = 0.08 * 35, v = 1 - (std::sqrt(d * d + rho * rho) - rho) / 35;
    return v * v * v;
  };
  const double want = (1 - w1) * 20 * a0 * sharp(d0) + w1 * 20 * a1 * sharp(d1);
  double sum = 0;
  for (int x = 0; x < 20; ++x) sum += out.gx[size_t(22) * 50 + x] * 3;
  EXPECT_NEAR(sum, want, 0.01);
}

// Per-vertex amplitudes interpolated at the closest point jump where the closest segment changes on
// the inner side of a bend (the two closest points differ there); the blend of the two nearest
// segments keeps the profile continuous. On a fine grid (0.1 m cells) a continuous profile changes
// by at most its slope (< 4) times 0.1 m between neighbours; the jump was ~2 m.
TEST(Tensor, ProfileIsContinuousOnTheInnerSideOfABend) {
  Device& d = test::device();
  GradientField g(800, 600);
  g.georef.cell_x = g.georef.cell_y = 0.1;
  GradientBuffers b = GradientBuffers::upload(d, g);
  Primitive c;
  c.shape = PrimitiveShape::Polyline;
  c.points = {{10, 50}, {40, 15}, {70, 50}};  // a peak at the top; the inner side is below it
  c.amplitude = {0.0, 40.0, 20.0};
  c.radius = 25;
  c.profile_amplitude = 1;
  add_profile_gradient(d, b, {c});
  GradientField out = g;
  b.download(d, out);
  double worst = 0;
  for (size_t i = 0; i < out.size(); ++i)
    worst = std::max({worst, std::abs(out.gx[i] * 0.1), std::abs(out.gy[i] * 0.1)});
  EXPECT_LT(worst, 0.6);
  EXPECT_GT(worst, 0.1);  // and the profile is there
}

TEST(Tensor, AlignedTensorsFollowTheStrokeAndTheClosestPoint) {
  const double mu = 0.9, phi = 60 * M_PI / 180;
  const double stroke = 30 * M_PI / 180;
  Primitive t;
  t.shape = PrimitiveShape::Polyline;
  t.points = {{-100 * std::cos(stroke), -100 * std::sin(stroke)}, {200 * std::cos(stroke), 200 * std::sin(stroke)}};
  t.radius = 1e4;  // alpha ~ 1 near the stroke
  t.tensor = TensorKind::Tangent;
  t.strength = mu;
  const GradientField out = apply(constant_field(6, 6, 1, std::cos(phi), std::sin(phi)), {t});
  const auto D = directional_tensor(stroke, mu);
  const size_t o = 2 * 6 + 2;
  // Face (2.5, 2) lies within a few metres of the stroke: alpha(d/r) = 1 to 1e-6.
  EXPECT_NEAR(out.gx[o], D[0] * std::cos(phi) + D[1] * std::sin(phi), 1e-4);
  Primitive c;
  c.shape = PrimitiveShape::Point;
  c.points = {{1000.0, 2.0}};  // far east on the row of the probed face: u(p) points east
  c.radius = 1e6;
  c.tensor = TensorKind::Closest;
  c.strength = mu;
  const GradientField out2 = apply(constant_field(6, 6, 1, std::cos(phi), std::sin(phi)), {c});
  const auto E = directional_tensor(0.0, mu);
  EXPECT_NEAR(out2.gx[o], E[0] * std::cos(phi) + E[1] * std::sin(phi), 1e-3);
}

TEST(Tensor, AnisotropicDistanceStretchesTheSupport) {
  Device& d = test::device();
  GradientField g(41, 41);
  GradientBuffers b = GradientBuffers::upload(d, g);
  Primitive p;
  p.shape = PrimitiveShape::Point;
  p.points = {{20.0, 20.0}};
  p.radius = 16;
  p.aniso_ratio = 2;  // offsets across the x axis (along y) count twice
  p.aniso_angle = 0;
  primitive_weight(d, b, {p}, full_box(41, 41), false);
  std::vector<float> w(g.size());
  d.queue().enqueueReadBuffer(b.mask, CL_TRUE, 0, w.size() * 4, w.data());
  EXPECT_NEAR(w[20 * 41 + 28], alpha(8.0 / 16), 1e-5);   // 8 m east: distance 8
  EXPECT_NEAR(w[24 * 41 + 20], alpha(8.0 / 16), 1e-5);   // 4 m south: distance 8
  EXPECT_EQ(w[28 * 41 + 20], 0.f);                       // 8 m south: distance 16, outside
  EXPECT_GT(w[20 * 41 + 34], 0.f);                       // 14 m east: still inside
}
