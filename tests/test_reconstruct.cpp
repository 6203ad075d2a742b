// SPDX-License-Identifier: Apache-2.0
// Multigrid reconstruction against manufactured solutions, a sparse direct solve and real DEMs.
#include "test_helpers.hpp"
#include "recon_reference.hpp"

#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>
#include <terracl/reconstruct.hpp>

#include <cstring>
#include <random>

using namespace terracl;

namespace {

struct Case {
  std::vector<double> exact;  // h*
  Heightfield f;              // divergence of h* (float)
  ConstraintSet c;
};

// Smooth h* in double, f = L h* exactly in double, `fixed` random hard cells taking h*.
Case manufactured(int W, int H, double cx, double cy, double fixed, unsigned seed) {
  Case k;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const double a = 1 + 2 * u(rng), b = 1 + 2 * u(rng), p = 6 * u(rng);
  k.exact.resize(size_t(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      k.exact[size_t(y) * W + x] = 800 + 200 * std::sin(a * x * 6.0 / (W + 3) + p) * std::cos(b * y * 5.0 / (H + 3)) +
                                   0.05 * x * cx - 0.03 * y * cy;
  const auto f = test::laplacian(k.exact, W, H, cx, cy);
  k.f = Heightfield(W, H);
  for (size_t i = 0; i < f.size(); ++i) k.f.z[i] = float(f[i]);
  k.f.georef.cell_x = cx;
  k.f.georef.cell_y = cy;
  k.c = ConstraintSet(W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (u(rng) < fixed) k.c.add_cell(x, y, k.exact[size_t(y) * W + x], ConstraintKind::Raster);
  if (k.c.empty()) k.c.add_cell(W / 2, H / 2, k.exact[size_t(H / 2) * W + W / 2], ConstraintKind::Point);
  return k;
}

// Reference for the float inputs actually solved: the direct solve with the float f and values.
std::vector<double> reference(const Case& k) {
  std::vector<double> f(k.f.z.begin(), k.f.z.end());
  return test::direct_solve(f, k.c.values(), k.f.width, k.f.height, k.f.georef.cell_x, k.f.georef.cell_y);
}

}  // namespace

TEST(Reconstruct, ManufacturedSolutionWithHardCells) {
  Case k = manufactured(97, 80, 10.0, 10.0, 0.01, 1);
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c);
  EXPECT_TRUE(r.converged || r.stagnated);
  EXPECT_LE(r.residuals.back(), 2e-6);
  const double range = test::range_of(k.exact);
  EXPECT_LT(test::max_abs_diff(r.height.z, k.exact), 1e-5 * range);
}

TEST(Reconstruct, AgreesWithEigenDirectSolve) {
  Case k = manufactured(45, 38, 30.0, 20.0, 0.02, 2);
  for (size_t i = 0; i < k.f.z.size(); i += 7) k.f.z[i] += 0.01f;  // not an exact Laplacian any more
  const auto ref = reference(k);
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c);
  EXPECT_LT(test::max_abs_diff(r.height.z, ref), 1e-5 * test::range_of(ref));
}

TEST(Reconstruct, HardCellsAreBitExact) {
  Case k = manufactured(64, 64, 5.0, 5.0, 0.05, 3);
  // values that are not representable after an offset round trip
  k.c.add_cell(10, 10, 1234.5678, ConstraintKind::Point);
  k.c.add_cell(0, 63, 0.1, ConstraintKind::Point);
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c);
  size_t checked = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      if (k.c.is_hard(x, y)) {
        ASSERT_EQ(r.height.at(x, y), k.c.value(x, y)) << x << "," << y;
        ++checked;
      }
  EXPECT_GT(checked, 100u);
}

TEST(Reconstruct, RealDemRoundTripWithinTolerance) {
  Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"), {});
  ASSERT_EQ(dem.count_nodata(), 0u);
  GradientField g = extract_gradient(test::device(), dem);
  ReconstructResult r = reconstruct(test::device(), g, ConstraintSet());
  const HeightStats s = compute_stats(dem);
  double err = 0;
  for (size_t i = 0; i < dem.size(); ++i) err = std::max(err, double(std::fabs(r.height.z[i] - dem.z[i])));
  EXPECT_LT(err, 1e-4 * (s.max - s.min)) << "cycles " << r.cycles;
  // With one anchor cell instead of the mean
  ConstraintSet c(dem.width, dem.height);
  c.add_cell(5, 7, dem.at(5, 7), ConstraintKind::Point);
  ReconstructResult a = reconstruct(test::device(), g, c);
  err = 0;
  for (size_t i = 0; i < dem.size(); ++i) err = std::max(err, double(std::fabs(a.height.z[i] - dem.z[i])));
  EXPECT_LT(err, 1e-4 * (s.max - s.min));
}

class CycleSmoother : public ::testing::TestWithParam<std::tuple<Cycle, Smoother>> {};

TEST_P(CycleSmoother, Converges) {
  Case k = manufactured(70, 53, 8.0, 8.0, 0.01, 4);
  const auto ref = reference(k);
  SolverOptions o;
  o.cycle = std::get<0>(GetParam());
  o.smoother = std::get<1>(GetParam());
  o.max_cycles = 60;
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c, o);
  EXPECT_TRUE(r.converged || r.stagnated) << "cycles " << r.cycles;
  EXPECT_LT(r.residuals.back(), 3e-6);
  EXPECT_LT(test::max_abs_diff(r.height.z, ref), 1e-5 * test::range_of(ref));
}

INSTANTIATE_TEST_SUITE_P(Reconstruct, CycleSmoother,
                         ::testing::Combine(::testing::Values(Cycle::V, Cycle::W, Cycle::Fmg),
                                            ::testing::Values(Smoother::Rbgs, Smoother::Jacobi)),
                         [](const auto& info) {
                           return std::string(cycle_name(std::get<0>(info.param))) + "_" +
                                  smoother_name(std::get<1>(info.param));
                         });

TEST(Reconstruct, VCycleConvergenceFactorBelowPointTwo) {
  Case k = manufactured(129, 129, 10.0, 10.0, 0.01, 5);
  for (size_t i = 0; i < k.f.z.size(); i += 5) k.f.z[i] += 0.003f;  // rough right-hand side
  SolverOptions o;
  o.cycle = Cycle::V;
  o.tolerance = 1e-7;
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c, o);
  ASSERT_GE(r.residuals.size(), 4u);
  // Average factor over the cycles above the float32 floor.
  int n = 0;
  double logsum = 0;
  for (size_t i = 1; i < r.residuals.size() && r.residuals[i] > 1e-5; ++i, ++n)
    logsum += std::log(r.residuals[i] / r.residuals[i - 1]);
  ASSERT_GT(n, 2);
  const double factor = std::exp(logsum / n);
  EXPECT_LT(factor, 0.2) << "V(2,2) convergence factor " << factor;
  RecordProperty("v_cycle_factor", std::to_string(factor));
}

TEST(Reconstruct, OddEvenNonSquareAndTinySizes) {
  const std::vector<std::pair<int, int>> sizes = {{1, 1}, {1, 7}, {2, 2}, {3, 5}, {8, 3},  {17, 4},
                                                  {64, 63}, {33, 65}, {100, 7}, {6, 90}, {130, 2}};
  unsigned seed = 10;
  for (auto [W, H] : sizes) {
    Case k = manufactured(W, H, 3.0, 4.0, 0.03, seed++);
    for (size_t i = 0; i < k.f.z.size(); i += 3) k.f.z[i] -= 0.02f;
    const auto ref = reference(k);
    SolverOptions o;
    o.tolerance = 1e-9;  // elongated grids with few hard cells are badly conditioned: go to the float floor
    ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c, o);
    EXPECT_TRUE(r.converged || r.stagnated) << W << "x" << H;
    EXPECT_LT(test::max_abs_diff(r.height.z, ref), 1e-5 * std::max(1.0, test::range_of(ref)))
        << W << "x" << H << " cycles " << r.cycles << " residual " << r.residuals.back();
  }
}

TEST(Reconstruct, AllCellsFixed) {
  Case k = manufactured(20, 13, 1.0, 1.0, 0.0, 6);
  for (int y = 0; y < 13; ++y)
    for (int x = 0; x < 20; ++x) k.c.add_cell(x, y, k.exact[size_t(y) * 20 + x] + 0.25, ConstraintKind::Raster);
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c);
  EXPECT_TRUE(r.converged);
  for (int y = 0; y < 13; ++y)
    for (int x = 0; x < 20; ++x) ASSERT_EQ(r.height.at(x, y), k.c.value(x, y));
}

TEST(Reconstruct, NoCellFixedKeepsTheMean) {
  Heightfield h = test::smooth_terrain(50, 40, 12.0, 300.0, 9);
  GradientField g = extract_gradient(test::device(), h);
  ReconstructResult r = reconstruct(test::device(), g, ConstraintSet());
  double mean = 0, err = 0;
  for (size_t i = 0; i < h.size(); ++i) mean += r.height.z[i], err = std::max(err, double(std::fabs(r.height.z[i] - h.z[i])));
  EXPECT_NEAR(mean / h.size(), g.mean_elevation, 1e-3);
  EXPECT_LT(err, 1e-4 * 600);
  SolverOptions o;
  o.mean = 10.0;
  ReconstructResult m = reconstruct(test::device(), g, ConstraintSet(), o);
  mean = 0;
  for (float v : m.height.z) mean += v;
  EXPECT_NEAR(mean / h.size(), 10.0, 1e-3);
  // divergence input with an inconsistent (non-zero mean) f is projected and still converges
  Heightfield f(30, 20, 0.5f);
  f.at(3, 3) = -2.0f;
  ReconstructResult d = reconstruct_divergence(test::device(), f, ConstraintSet());
  EXPECT_TRUE(d.converged || d.stagnated);
}

TEST(Reconstruct, NaNInputIsRejected) {
  GradientField g(10, 10);
  g.gx[17] = NAN;
  EXPECT_THROW(reconstruct(test::device(), g, ConstraintSet()), Error);
  Heightfield f(10, 10, 0.f);
  f.z[3] = INFINITY;
  EXPECT_THROW(reconstruct_divergence(test::device(), f, ConstraintSet()), Error);
  ConstraintSet c(10, 10);
  EXPECT_THROW(c.add_cell(1, 1, NAN, ConstraintKind::Point), Error);
  ConstraintSet wrong(9, 10);
  EXPECT_THROW(reconstruct(test::device(), GradientField(10, 10), wrong), Error);
}

TEST(Reconstruct, WarmStartFromTheSolutionNeedsNoCycle) {
  Case k = manufactured(60, 40, 5.0, 5.0, 0.01, 7);
  ReconstructResult first = reconstruct_divergence(test::device(), k.f, k.c);
  SolverOptions o;
  o.initial = &first.height;
  o.tolerance = 1e-5;
  ReconstructResult again = reconstruct_divergence(test::device(), k.f, k.c, o);
  EXPECT_EQ(again.cycles, 0);
  EXPECT_LT(again.residuals.front(), 1e-5);
  EXPECT_LT(test::max_abs_diff(again.height.z, std::vector<double>(first.height.z.begin(), first.height.z.end())),
            1e-3);
}

TEST(Reconstruct, DirichletBorderTakesTheInitialValues) {
  Case k = manufactured(40, 30, 5.0, 5.0, 0.0, 8);
  Heightfield init(40, 30);
  for (size_t i = 0; i < init.size(); ++i) init.z[i] = float(k.exact[i]);
  SolverOptions o;
  o.dirichlet_border = true;
  o.initial = &init;
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, ConstraintSet(), o);
  EXPECT_EQ(r.height.at(0, 5), init.at(0, 5));
  EXPECT_EQ(r.height.at(39, 29), init.at(39, 29));
  EXPECT_LT(test::max_abs_diff(r.height.z, k.exact), 1e-5 * test::range_of(k.exact));
}

TEST(Reconstruct, CascadeRunsButStaysAwayFromTheSolution) {
  Case k = manufactured(129, 129, 10.0, 10.0, 0.01, 11);
  SolverOptions o;
  o.cycle = Cycle::Cascade;
  ReconstructResult c = reconstruct_divergence(test::device(), k.f, k.c, o);
  ReconstructResult v = reconstruct_divergence(test::device(), k.f, k.c);
  EXPECT_EQ(c.cycles, 1);
  const double ec = test::max_abs_diff(c.height.z, k.exact), ev = test::max_abs_diff(v.height.z, k.exact);
  EXPECT_TRUE(std::isfinite(ec));
  EXPECT_GT(ec, 10 * ev);  // the published one-pass schedule is not converged
  EXPECT_GT(c.residuals.back(), 1e-5);
  for (float z : c.height.z) ASSERT_TRUE(std::isfinite(z));
}

TEST(Reconstruct, ReportJson) {
  Case k = manufactured(30, 30, 1.0, 1.0, 0.02, 12);
  ReconstructResult r = reconstruct_divergence(test::device(), k.f, k.c);
  const auto j = r.to_json();
  EXPECT_EQ(j.at("cycles").get<int>(), r.cycles);
  EXPECT_EQ(j.at("relative_residuals").size(), r.residuals.size());
  EXPECT_FALSE(j.at("device").get<std::string>().empty());
  EXPECT_GT(j.at("device_bytes").get<uint64_t>(), 0u);
  EXPECT_EQ(multigrid_levels(1025, 1025).size(), 9u);
  EXPECT_EQ(multigrid_levels(1025, 1025).back(), std::make_pair(5, 5));
}

// The device-resident entry point (used by the editor) solves the same problem as the host one.
TEST(Reconstruct, DeviceBuffersGiveTheSameResultAsHostGradients) {
  Device& d = test::device();
  const Heightfield h = test::smooth_terrain(61, 45, 12.0, 300.0, 4);
  const GradientField g = extract_gradient(d, h);
  ConstraintSet c(61, 45);
  c.add_cell(10, 7, h.at(10, 7) + 5.0f, ConstraintKind::Point);
  c.add_cell(50, 30, h.at(50, 30) - 3.0f, ConstraintKind::Point);
  const size_t bytes = g.size() * sizeof(float);
  cl::Buffer gx = d.buffer(bytes, CL_MEM_READ_ONLY, "test gx"), gy = d.buffer(bytes, CL_MEM_READ_ONLY, "test gy");
  d.queue().enqueueWriteBuffer(gx, CL_FALSE, 0, bytes, g.gx.data());
  d.queue().enqueueWriteBuffer(gy, CL_TRUE, 0, bytes, g.gy.data());
  const ReconstructResult a = reconstruct(d, g, c), b = reconstruct_device(d, gx, gy, g, c);
  EXPECT_EQ(a.cycles, b.cycles);
  EXPECT_EQ(a.height.z, b.height.z);
  EXPECT_EQ(b.height.at(10, 7), h.at(10, 7) + 5.0f);
  // Buffers smaller than the grid are refused.
  cl::Buffer small = d.buffer(16, CL_MEM_READ_ONLY, "small");
  EXPECT_THROW(reconstruct_device(d, small, gy, g, c), Error);
}

// TERRACL_PHASES: the phase breakdown is reported, adds up to the total, and changes no bit.
TEST(Reconstruct, PhaseBreakdownIsCompleteAndChangesNoResult) {
  Case k = manufactured(97, 66, 2.0, 3.0, 0.02, 11);
  Heightfield h(97, 66);
  for (size_t i = 0; i < h.size(); ++i) h.z[i] = float(k.exact[i]);
  h.georef.cell_x = 2.0;
  h.georef.cell_y = 3.0;
  GradientField g = extract_gradient(test::device(), h);
  ReconstructResult plain = reconstruct(test::device(), g, k.c);
  EXPECT_TRUE(plain.phases_ms.empty());
  EXPECT_FALSE(plain.to_json().contains("phases_ms"));
  setenv("TERRACL_PHASES", "1", 1);
  ReconstructResult timed = reconstruct(test::device(), g, k.c);
  unsetenv("TERRACL_PHASES");
  ASSERT_EQ(plain.height.z.size(), timed.height.z.size());
  EXPECT_EQ(0, std::memcmp(plain.height.z.data(), timed.height.z.data(), plain.height.z.size() * sizeof(float)));
  std::vector<std::string> names;
  double sum = 0;
  for (const auto& [n, v] : timed.phases_ms) {
    names.push_back(n);
    EXPECT_GE(v, 0.0) << n;
    sum += v;
  }
  const std::vector<std::string> want{"host constraints", "device init", "upload", "hierarchy", "cycles",
                                      "refinement", "solver other", "read-back", "host finish"};
  EXPECT_EQ(names, want);
  EXPECT_LE(sum, timed.total_ms + 1e-6);
  EXPECT_GE(sum, 0.9 * timed.total_ms);
  EXPECT_TRUE(timed.to_json().contains("phases_ms"));
}
