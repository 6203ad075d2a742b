// SPDX-License-Identifier: Apache-2.0
// `terracl extract` / `terracl reconstruct` / `terracl bench reconstruct` as a user runs them.
#include "test_helpers.hpp"

#include <terracl/hypre.hpp>
#include <terracl/io.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

using namespace terracl;

TEST(ReconstructCli, ExtractThenReconstructRoundTripsARealDem) {
  test::TempDir dir;
  const std::string dem = test::data_path("crops/presidential_128x96.tif");
  auto e = test::run_cli("extract " + dem + " -o " + dir.path("g.exr") + " -q");
  ASSERT_EQ(e.exit_code, 0) << e.out;
  auto r = test::run_cli("reconstruct --gradient " + dir.path("g.exr") + " --report " + dir.path("r.json") + " -o " +
                         dir.path("out.tif") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  Heightfield a = read_heightfield(dem), b = read_heightfield(dir.path("out.tif"));
  ASSERT_EQ(a.size(), b.size());
  const HeightStats s = compute_stats(a);
  double err = 0;
  for (size_t i = 0; i < a.size(); ++i) err = std::max(err, double(std::fabs(a.z[i] - b.z[i])));
  EXPECT_LT(err, 1e-4 * (s.max - s.min));
  std::ifstream in(dir.path("r.json"));
  const auto j = nlohmann::json::parse(in);
  EXPECT_GE(j.at("cycles").get<int>(), 1);
  EXPECT_LE(j.at("final_relative_residual").get<double>(), 1e-5);
  EXPECT_TRUE(j.contains("device"));
  EXPECT_TRUE(j.contains("total_ms"));
  // the gradient as positional input works too, with constraints from rasters
  Heightfield mask(128, 96, 0.f), elev(128, 96, 0.f);
  mask.at(10, 10) = 1.f;
  elev.at(10, 10) = 2000.f;
  write_heightfield(mask, dir.path("mask.tif"));
  write_heightfield(elev, dir.path("elev.tif"));
  auto m = test::run_cli("reconstruct " + dir.path("g.exr") + " --fixed-mask " + dir.path("mask.tif") +
                         " --fixed-elevation " + dir.path("elev.tif") + " --cycle v --smoother jacobi -o " +
                         dir.path("m.tif") + " -q");
  ASSERT_EQ(m.exit_code, 0) << m.out;
  EXPECT_EQ(read_heightfield(dir.path("m.tif")).at(10, 10), 2000.f);
}

TEST(ReconstructCli, ConstraintJsonAndItsErrors) {
  test::TempDir dir;
  const std::string dem = test::data_path("crops/frontrange_64.asc");
  ASSERT_EQ(test::run_cli("extract " + dem + " -o " + dir.path("g.exr") + " -q").exit_code, 0);
  std::ofstream(dir.path("c.json")) << R"({"points": [{"x": 5, "y": 6, "z": 3000.5}],
    "polygons": [{"points": [[20, 20], [30, 20], [30, 30]], "z": 2500}]})";
  auto ok = test::run_cli("reconstruct --gradient " + dir.path("g.exr") + " --constraints " + dir.path("c.json") +
                          " -o " + dir.path("o.tif") + " -q");
  ASSERT_EQ(ok.exit_code, 0) << ok.out;
  Heightfield o = read_heightfield(dir.path("o.tif"));
  EXPECT_EQ(o.at(5, 6), 3000.5f);
  EXPECT_EQ(o.at(28, 22), 2500.f);
  std::ofstream(dir.path("bad.json")) << R"({"points": [{"x": 5, "y": 600, "z": 1}]})";
  const size_t before = dir.count();
  auto bad = test::run_cli("reconstruct --gradient " + dir.path("g.exr") + " --constraints " + dir.path("bad.json") +
                           " -o " + dir.path("bad.tif") + " -q");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("bad.json/points/0"), std::string::npos) << bad.out;
  EXPECT_EQ(dir.count(), before);  // nothing half-written
}

TEST(ReconstructCli, CascadeReportShowsTheDistanceToTheConvergedSolution) {
  test::TempDir dir;
  const std::string dem = test::data_path("crops/presidential_128x96.tif");
  ASSERT_EQ(test::run_cli("extract " + dem + " -o " + dir.path("g.exr") + " -q").exit_code, 0);
  auto r = test::run_cli("reconstruct --gradient " + dir.path("g.exr") + " --cycle cascade --report " +
                         dir.path("r.json") + " -o " + dir.path("c.tif") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::ifstream in(dir.path("r.json"));
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("cycle"), "cascade");
  EXPECT_GT(j.at("converged_reference").at("max_difference_m").get<double>(), 0.0);
  EXPECT_LT(j.at("converged_reference").at("final_relative_residual").get<double>(), 1e-5);
}

TEST(ReconstructCli, UsageErrors) {
  test::TempDir dir;
  auto none = test::run_cli("reconstruct -o " + dir.path("o.tif") + " -q");
  EXPECT_NE(none.exit_code, 0);
  EXPECT_NE(none.out.find("gradient"), std::string::npos) << none.out;
  auto cyc = test::run_cli("reconstruct --gradient x.exr --cycle z -o " + dir.path("o.tif"));
  EXPECT_NE(cyc.exit_code, 0);
  EXPECT_EQ(dir.count(), 0u);
}

TEST(ReconstructCli, BenchPrintsTheFigures) {
  auto b = test::run_cli("bench reconstruct --size 65 --repeats 2");
  ASSERT_EQ(b.exit_code, 0) << b.out;
  for (const char* key : {"median_ms", "cycles", "final_relative_residual", "max_error_m", "device_memory_mb"})
    EXPECT_NE(b.out.find(key), std::string::npos) << key << "\n" << b.out;
}

// --solver hypre: a clear error in builds without hypre (the default build); with -DTERRACL_MPI=ON
// it solves (tests/hypre/ checks its answers).
TEST(ReconstructCli, SolverHypreIsRefusedWithoutHypreAndRunsWithIt) {
  test::TempDir dir;
  const std::string dem = test::data_path("crops/frontrange_64.asc");
  ASSERT_EQ(test::run_cli("extract " + dem + " -o " + dir.path("g.exr") + " -q").exit_code, 0);
  const auto r = test::run_cli("reconstruct " + dir.path("g.exr") + " --solver hypre -o " + dir.path("out.tif") + " -q");
  if (hypre_available()) {
    EXPECT_EQ(r.exit_code, 0) << r.out;
    EXPECT_TRUE(std::filesystem::exists(dir.path("out.tif")));
  } else {
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.out.find("--solver hypre: this build has no hypre (configure with -DTERRACL_MPI=ON"), std::string::npos)
        << r.out;
    EXPECT_FALSE(std::filesystem::exists(dir.path("out.tif")));
  }
  const auto bad = test::run_cli("reconstruct " + dir.path("g.exr") + " --solver petsc -o " + dir.path("x.tif"));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("hypre"), std::string::npos) << bad.out;  // the choices are listed
}
