// SPDX-License-Identifier: Apache-2.0
// hypre back end of the reconstruction (builds with -DTERRACL_MPI=ON; ctest label `mpi`): the
// same discrete problem as the device multigrid, checked against an Eigen direct solve and
// against the device on a real DEM crop. 2 ranks vs 1: scripts/hypre-ranks-check.sh.
#include "recon_reference.hpp"
#include "test_helpers.hpp"

#include <terracl/constraints.hpp>
#include <terracl/gradient.hpp>
#include <terracl/hypre.hpp>
#include <terracl/io.hpp>
#include <terracl/reconstruct.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <sys/wait.h>
#include <unistd.h>

using namespace terracl;


namespace {

// The divergence of a staggered gradient in double (what both solvers invert).
std::vector<double> divergence_of(const GradientField& g) {
  const int W = g.width, H = g.height;
  const double cx = g.georef.cell_x, cy = g.georef.cell_y;
  std::vector<double> f(g.size());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      const double ex = x + 1 < W ? g.gx[i] : 0.0, wx = x > 0 ? g.gx[i - 1] : 0.0;
      const double sy = y + 1 < H ? g.gy[i] : 0.0, ny = y > 0 ? g.gy[i - W] : 0.0;
      f[i] = (ex - wx) / cx + (sy - ny) / cy;
    }
  return f;
}

GradientField staggered_of(const Heightfield& h) {
  GradientField g(h.width, h.height);
  g.georef = h.georef;
  const int W = h.width, H = h.height;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      g.gx[i] = x + 1 < W ? float((double(h.z[i + 1]) - h.z[i]) / h.georef.cell_x) : 0.f;
      g.gy[i] = y + 1 < H ? float((double(h.z[i + W]) - h.z[i]) / h.georef.cell_y) : 0.f;
    }
  return g;
}

SolverOptions hypre_options(double tol = 1e-11) {
  SolverOptions o;
  o.solver = Solver::Hypre;
  o.tolerance = tol;
  o.max_cycles = 500;
  return o;
}

}  // namespace

// Anisotropic cells, hard values off the terrain (so they shape the solution), a hard cell on the
// border and two neighbouring hard cells: hypre == Eigen's LDLT of the same system.
TEST(Hypre, MatchesTheEigenDirectSolve) {
  const int W = 41, H = 29;
  Heightfield h = test::smooth_terrain(W, H, 10.0, 300.0, 3);
  h.georef.cell_x = 10.0;
  h.georef.cell_y = 7.0;
  const GradientField g = staggered_of(h);
  ConstraintSet c(W, H);
  std::vector<float> fixed(size_t(W) * H, NAN);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> px(0, W - 1), py(0, H - 1);
  auto fix = [&](int x, int y, float z) {
    c.add_cell(x, y, z, ConstraintKind::Raster);
    fixed[size_t(y) * W + x] = z;
  };
  for (int k = 0; k < 12; ++k) {
    const int x = px(rng), y = py(rng);
    fix(x, y, h.z[size_t(y) * W + x] + 40.0f * float(k % 3 - 1));
  }
  fix(0, 5, 900.f);
  fix(20, 0, 1100.f);
  fix(21, 0, 1105.f);
  const ReconstructResult r = reconstruct(test::device(), g, c, hypre_options());
  EXPECT_EQ(r.solver, "hypre");
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.residuals.back(), 1e-11);
  const std::vector<double> ref = test::direct_solve(divergence_of(g), fixed, W, H, 10.0, 7.0);
  const double range = test::range_of(ref);
  std::printf("hypre vs Eigen: %.3e m of a %.1f m range, %d CG iterations\n", test::max_abs_diff(r.height.z, ref),
              range, r.cycles);
  EXPECT_LT(test::max_abs_diff(r.height.z, ref), 1e-6 * range) << "range " << range;
  for (size_t i = 0; i < fixed.size(); ++i)
    if (!std::isnan(fixed[i])) EXPECT_EQ(r.height.z[i], fixed[i]) << "hard cell " << i;
}

// No hard cell: the pure-Neumann problem (pinned and shifted to the mean) returns the terrain.
TEST(Hypre, PureNeumannRoundTripKeepsTheMean) {
  const int W = 37, H = 30;
  const Heightfield h = test::smooth_terrain(W, H, 20.0, 400.0, 9);
  GradientField g = staggered_of(h);
  double mean = 0, lo = 1e30, hi = -1e30;
  for (float v : h.z) mean += v, lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
  mean /= double(h.size());
  SolverOptions o = hypre_options();
  o.mean = mean;
  const ReconstructResult r = reconstruct(test::device(), g, ConstraintSet(), o);
  EXPECT_TRUE(r.converged);
  double err = 0, rmean = 0;
  for (size_t i = 0; i < h.size(); ++i) err = std::max(err, std::fabs(double(r.height.z[i]) - h.z[i])), rmean += r.height.z[i];
  EXPECT_LT(err, 1e-5 * (hi - lo));
  EXPECT_NEAR(rmean / double(h.size()), mean, 1e-3);
}

// The issue's acceptance: a real DEM crop's gradient with a few hard constraints, hypre vs the
// device multigrid (refined to double accuracy) equal to 1e-5 of the range; the plain float
// multigrid too.
TEST(Hypre, EqualsTheDeviceMultigridOnADemCrop) {
  const Heightfield dem = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  const int W = 193, H = 161, x0 = 300, y0 = 250;
  Heightfield crop(W, H);
  crop.georef = dem.georef;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) crop.z[size_t(y) * W + x] = dem.z[size_t(y + y0) * dem.width + x + x0];
  const GradientField g = extract_gradient(test::device(), crop);
  ConstraintSet c(W, H);
  // A raised summit, a lowered valley cell, a short ridge line and a corner.
  c.add_cell(40, 30, crop.z[30 * W + 40] + 60.f, ConstraintKind::Point);
  c.add_cell(150, 120, crop.z[120 * W + 150] - 45.f, ConstraintKind::Point);
  for (int x = 80; x < 110; ++x) c.add_cell(x, 70, crop.z[70 * W + 80] + 10.f, ConstraintKind::Polyline);
  c.add_cell(W - 1, H - 1, crop.z[size_t(H) * W - 1], ConstraintKind::Point);

  const ReconstructResult hy = reconstruct(test::device(), g, c, hypre_options(1e-10));
  ASSERT_TRUE(hy.converged);
  SolverOptions mo;
  mo.refine = Refinement::Auto;
  const ReconstructResult mg = reconstruct(test::device(), g, c, mo);
  SolverOptions fo;
  const ReconstructResult mf = reconstruct(test::device(), g, c, fo);
  double lo = 1e30, hi = -1e30, d_ref = 0, d_float = 0;
  for (size_t i = 0; i < hy.height.size(); ++i) {
    lo = std::min<double>(lo, hy.height.z[i]);
    hi = std::max<double>(hi, hy.height.z[i]);
    d_ref = std::max(d_ref, std::fabs(double(hy.height.z[i]) - mg.height.z[i]));
    d_float = std::max(d_float, std::fabs(double(hy.height.z[i]) - mf.height.z[i]));
  }
  std::printf("range %.1f m: hypre (%d CG iterations) vs refined multigrid %.3e m, vs float multigrid %.3e m\n",
              hi - lo, hy.cycles, d_ref, d_float);
  EXPECT_GT(hi - lo, 100.0);
  EXPECT_LT(d_ref, 1e-5 * (hi - lo)) << "hypre vs refined multigrid, range " << hi - lo;
  EXPECT_LT(d_float, 1e-4 * (hi - lo)) << "hypre vs float multigrid, range " << hi - lo;
  // And not by accident: the constraints moved the terrain far more than that.
  double moved = 0;
  for (size_t i = 0; i < crop.size(); ++i) moved = std::max(moved, std::fabs(double(hy.height.z[i]) - crop.z[i]));
  EXPECT_GT(moved, 10.0);
}

// The stage and the CLI: --solver hypre writes the result and a report naming the solver.
TEST(Hypre, CliSolverOptionAndReport) {
  test::TempDir t;
  ASSERT_TRUE(hypre_available());
  const Heightfield h = test::smooth_terrain(65, 49, 10.0, 200.0, 4);
  GradientField g = staggered_of(h);
  g.mean_elevation = 0;
  for (float v : h.z) g.mean_elevation += v / double(h.size());
  write_gradient(g, t.path("g.exr"));
  const auto r = test::run_cli("reconstruct " + t.path("g.exr") + " --solver hypre --tolerance 1e-10 --max-cycles 200 -o " +
                               t.path("out.tif") + " --report " + t.path("r.json"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(t.path("r.json")));
  EXPECT_EQ(j["solver"], "hypre");
  EXPECT_EQ(j["mpi_ranks"], 1);
  EXPECT_LE(j["final_relative_residual"].get<double>(), 1e-10);
  const Heightfield out = read_heightfield(t.path("out.tif"));
  double err = 0;
  for (size_t i = 0; i < h.size(); ++i) err = std::max(err, std::fabs(double(out.z[i]) - h.z[i]));
  EXPECT_LT(err, 1e-3);
  // An iteration limit too small: a clear error, no output.
  const auto bad = test::run_cli("reconstruct " + t.path("g.exr") + " --solver hypre --tolerance 1e-12 --max-cycles 1 -o " +
                                 t.path("bad.tif"));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("did not converge in 1 CG iterations"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(t.path("bad.tif")));
}

// `reconstruct GRAD.exr --solver hypre` reads the file by bands of rows (each MPI rank its own,
// plus the halo row above): the result equals the library's solve of the whole gradient loaded
// in memory, bit for bit, without constraints (mean from the file) and with a constraint file.
TEST(Hypre, BandReadOfTheGradientFileEqualsTheWholeRead) {
  test::TempDir t;
  const Heightfield h = test::smooth_terrain(71, 53, 10.0, 300.0, 5);
  GradientField g = staggered_of(h);
  g.georef = h.georef;
  g.mean_elevation = 0;
  for (float v : h.z) g.mean_elevation += v / double(h.size());
  write_gradient(g, t.path("g.exr"));
  std::ofstream(t.path("c.json")) << R"({"units": "pixels", "points": [{"x": 20, "y": 10, "z": 900}],
    "polylines": [{"points": [[5, 40, 100], [60, 30, 150]], "width": 1}]})";
  const GradientField whole = read_gradient(t.path("g.exr"));
  for (const bool constrained : {false, true}) {
    const std::string extra = constrained ? " --constraints " + t.path("c.json") : "";
    const auto r = test::run_cli("reconstruct " + t.path("g.exr") + " --solver hypre --tolerance 1e-9 --max-cycles 300" +
                                 extra + " -o " + t.path("band.tif") + " --report " + t.path("r.json"));
    ASSERT_EQ(r.exit_code, 0) << r.out;
    // The CLI took the band reader (not a whole read of its input).
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(t.path("r.json")));
    EXPECT_NE(j["device"].get<std::string>().find("input read by bands of rows"), std::string::npos) << j["device"];
    ConstraintSet c(whole.width, whole.height);
    if (constrained) add_constraints_file(c, t.path("c.json"), whole.georef, nullptr);
    SolverOptions o = hypre_options(1e-9);
    o.max_cycles = 300;
    const ReconstructResult ref = reconstruct(test::device(), whole, c, o);
    const Heightfield band = read_heightfield(t.path("band.tif"));
    ASSERT_EQ(band.z.size(), ref.height.z.size());
    size_t differ = 0;
    for (size_t i = 0; i < band.z.size(); ++i) differ += band.z[i] != ref.height.z[i];
    EXPECT_EQ(differ, 0u) << (constrained ? "with" : "without") << " constraints";
    if (constrained) EXPECT_EQ(band.z[10 * 71 + 20], 900.f);
  }
}

// Every input of `reconstruct --solver hypre` read by bands (central gradients, --divergence,
// --initial, --border dirichlet, --fixed-mask/--fixed-elevation, a constraint file with omitted
// z and a frozen polygon; two runs cover them all) equals the library's solve of the whole fields loaded in memory, bit
// for bit (one rank here; 2 and 3 ranks: scripts/hypre-ranks-check.sh).
TEST(Hypre, BandReadsOfEveryInputEqualTheWholeReads) {
  test::TempDir t;
  const int W = 67, H = 51;
  Heightfield h = test::smooth_terrain(W, H, 10.0, 300.0, 8);
  h.georef.cell_x = 10.0;
  h.georef.cell_y = 12.0;
  Heightfield start = h;  // a start/border field off the terrain, so that it shows
  for (size_t i = 0; i < start.size(); ++i) start.z[i] += 20.0f * std::sin(0.1 * double(i % W)) + 3.0f;
  Heightfield mask(W, H, 0.f), elev(W, H, 0.f);
  mask.georef = elev.georef = h.georef;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      mask.z[size_t(y) * W + x] = (x * 5 + y * 3) % 41 == 0 ? 1.f : 0.f;
      elev.z[size_t(y) * W + x] = 500.f + 2.f * x - y;
    }
  const GradientField central = extract_gradient(test::device(), h, GradientFormat::Central);
  ASSERT_EQ(gradient_format(central), GradientFormat::Central);
  write_gradient(central, t.path("gc.exr"));
  const GradientField stag = staggered_of(h);
  Heightfield div(W, H);
  div.georef = h.georef;
  const std::vector<double> dv = divergence_of(stag);
  for (size_t i = 0; i < dv.size(); ++i) div.z[i] = float(dv[i]);
  write_heightfield(div, t.path("div.tif"));
  write_heightfield(start, t.path("start.tif"));
  write_heightfield(mask, t.path("mask.tif"));
  write_heightfield(elev, t.path("elev.tif"));
  std::ofstream(t.path("c.json")) << R"({"units": "pixels", "points": [{"x": 20, "y": 10, "z": 900}, [50, 40]],
    "polylines": [{"points": [[5, 40], [60, 30, 150]], "width": 2}],
    "polygons": [{"points": [[30, 5], [45, 8], [40, 20]]}]})";
  // What the files hold, read whole (the reference solves' inputs).
  const GradientField gc = read_gradient(t.path("gc.exr"));
  const Heightfield fdiv = read_heightfield(t.path("div.tif")), fstart = read_heightfield(t.path("start.tif"));
  const Heightfield fmask = read_heightfield(t.path("mask.tif")), felev = read_heightfield(t.path("elev.tif"));

  struct Case {
    std::string name, args;
    bool use_div, rasters, file, border;
  };
  const std::string files = " --fixed-mask " + t.path("mask.tif") + " --fixed-elevation " + t.path("elev.tif") +
                            " --constraints " + t.path("c.json");
  const std::vector<Case> cases = {
      {"central + initial + dirichlet border + rasters + file",
       t.path("gc.exr") + " --initial " + t.path("start.tif") + " --border dirichlet" + files, false, true, true, true},
      {"divergence, no start", "--divergence " + t.path("div.tif") + " --mean 7", true, false, false, false},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.name);
    const auto r = test::run_cli("reconstruct " + k.args + " --solver hypre --tolerance 1e-9 --max-cycles 300 -o " +
                                 t.path("band.tif") + " --report " + t.path("r.json"));
    ASSERT_EQ(r.exit_code, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(t.path("r.json")));
    EXPECT_NE(j["device"].get<std::string>().find("input read by bands of rows"), std::string::npos) << j["device"];
    const bool with_start = k.args.find("--initial") != std::string::npos;
    ConstraintSet c(W, H);
    if (k.rasters) c.add_rasters(fmask, felev, t.path("mask.tif"));
    if (k.file) add_constraints_file(c, t.path("c.json"), gc.georef, &fstart);
    SolverOptions o = hypre_options(1e-9);
    o.max_cycles = 300;
    if (with_start) o.initial = &fstart;
    o.dirichlet_border = k.border;
    if (k.args.find("--mean 7") != std::string::npos) o.mean = 7.0;
    const ReconstructResult ref =
        k.use_div ? reconstruct_divergence(test::device(), fdiv, c, o) : reconstruct(test::device(), gc, c, o);
    const Heightfield band = read_heightfield(t.path("band.tif"));
    ASSERT_EQ(band.z.size(), ref.height.z.size());
    size_t differ = 0;
    for (size_t i = 0; i < band.z.size(); ++i) differ += band.z[i] != ref.height.z[i];
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(j["hard_cells"].get<size_t>(), ref.hard_cells);
    if (k.file) EXPECT_EQ(band.z[10 * W + 20], 900.f);
    if (k.border) EXPECT_EQ(band.z[1], fstart.z[1]);  // (0, 0) also has a mask cell: averaged
  }
}

// A pipeline that reads a gradient file straight into a hypre reconstruct leaves the reading to
// the stage (by bands): the same bytes as the library's whole-field solve, and the report names
// the band reader.
TEST(Hypre, PipelineReadIntoHypreReconstructReadsByBands) {
  test::TempDir t;
  const Heightfield h = test::smooth_terrain(59, 45, 10.0, 300.0, 6);
  GradientField g = staggered_of(h);
  g.mean_elevation = 123.0;
  write_gradient(g, t.path("g.exr"));
  std::ofstream(t.path("p.json")) << nlohmann::json::array(
      {t.path("g.exr"),
       {{"type", "reconstruct"}, {"solver", "hypre"}, {"tolerance", 1e-9}, {"max_cycles", 300}, {"report", t.path("r.json")}},
       t.path("out.tif")});
  const auto r = test::run_cli("run " + t.path("p.json"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(t.path("r.json")));
  EXPECT_NE(j["device"].get<std::string>().find("input read by bands of rows"), std::string::npos) << j["device"];
  SolverOptions o = hypre_options(1e-9);
  o.max_cycles = 300;
  const ReconstructResult ref = reconstruct(test::device(), read_gradient(t.path("g.exr")), ConstraintSet(), o);
  const Heightfield out = read_heightfield(t.path("out.tif"));
  ASSERT_EQ(out.z.size(), ref.height.z.size());
  size_t differ = 0;
  for (size_t i = 0; i < out.z.size(); ++i) differ += out.z[i] != ref.height.z[i];
  EXPECT_EQ(differ, 0u);
}
