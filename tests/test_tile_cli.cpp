// SPDX-License-Identifier: Apache-2.0
// `terracl run --tile` as a user runs it: the memory bound (peak RSS independent of the raster
// size, under a deliberately small --memory-budget), progress per tile, and usage errors.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <terracl/io.hpp>
#include <vector>

#include "test_helpers.hpp"

namespace terracl {
namespace {

double peak_rss_mib(const std::vector<std::string>& args) { return test::cli_peak_rss_mib(args); }

// A w x h raster of the SRTM tile repeated (real relief, real depressions).
std::string big_input(const test::TempDir& dir, int w, int h) {
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  Heightfield t(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) t.at(x, y) = dem.at(x % 1200, y % 1200);
  const std::string f = dir.path("in" + std::to_string(w) + ".tif");
  write_heightfield(t, f);
  return f;
}

std::string pipeline(const test::TempDir& dir, const std::string& in, const std::string& name, bool fill) {
  const std::string p = dir.path(name + ".json");
  std::ofstream(p) << R"([")" << in << R"(", )" << (fill ? R"("fill_depressions", )" : "")
                   << R"({"type": "crop", "x": 1, "y": 1}, {"type": "downsample", "factor": 2}, ")"
                   << dir.path(name + ".tif") << R"("])";
  return p;
}

TEST(TileCli, PeakMemoryStaysBoundedUnderASmallBudget) {
  test::TempDir dir;
  // 2400^2 float32 is 22 MiB per copy; the budget (16 MiB) cannot hold one.
  const std::string small = pipeline(dir, big_input(dir, 600, 600), "small", false);
  const std::string large = pipeline(dir, big_input(dir, 2400, 2400), "large", false);
  const std::vector<std::string> tiled = {"-q", "run", "--memory-budget", "16M"};
  auto with = [](std::vector<std::string> v, const std::string& p) {
    v.push_back(p);
    return v;
  };
  const double rss_small = peak_rss_mib(with(tiled, small));
  const double rss_large = peak_rss_mib(with(tiled, large));
  const double rss_untiled = peak_rss_mib({"-q", "run", large, "--set", "write.filename=" + dir.path("large_u.tif")});
  ASSERT_GT(rss_small, 0);
  ASSERT_GT(rss_large, 0);
  ASSERT_GT(rss_untiled, 0);
  // 16x the cells, the same memory (within the budget)...
  EXPECT_LT(rss_large - rss_small, 8.0) << rss_small << " MiB for 600^2, " << rss_large << " MiB for 2400^2";
  // ...while the untiled run holds copies of the raster: the measure can fail.
  const double raster_mib = 2400.0 * 2400 * 4 / (1 << 20);
  EXPECT_GT(rss_untiled - rss_large, 1.2 * raster_mib) << rss_untiled << " MiB untiled, " << rss_large << " MiB tiled";
  EXPECT_EQ(read_heightfield(dir.path("large.tif")).z, read_heightfield(dir.path("large_u.tif")).z);
}

// The tiled fill's perimeter graph grows as tiles shrink: the automatic tile is the largest one
// with which the graph and the tile fit together (at 2400^2 under 32 MiB: 512, where the largest
// tile alone, 768, left no room for its graph and the run was refused).
TEST(TileCli, FillUnderABudgetChoosesATileItsGraphFitsWith) {
  test::TempDir dir;
  const std::string in = big_input(dir, 2400, 2400);
  const auto tiled = test::run_cli("-q fill_depressions " + in + " -o " + dir.path("t.tif") + " --memory-budget 32M");
  ASSERT_EQ(tiled.exit_code, 0) << tiled.out;
  const auto untiled = test::run_cli("-q fill_depressions " + in + " -o " + dir.path("u.tif"));
  ASSERT_EQ(untiled.exit_code, 0) << untiled.out;
  EXPECT_EQ(read_heightfield(dir.path("t.tif")).z, read_heightfield(dir.path("u.tif")).z);
}

TEST(TileCli, ProgressPerTileAndUsageErrors) {
  test::TempDir dir;
  const std::string p = pipeline(dir, big_input(dir, 300, 200), "p", true);
  const auto r = test::run_cli("--progress=json run " + p + " --tile 128");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("tile 6/6"), std::string::npos) << r.out;  // the crop's 6 tiles
  EXPECT_NE(r.out.find("\"event\":\"done\""), std::string::npos) << r.out;
  const auto bad_budget = test::run_cli("run " + p + " --memory-budget lots");
  EXPECT_EQ(bad_budget.exit_code, 2) << bad_budget.out;
  EXPECT_NE(bad_budget.out.find("--memory-budget: 'lots' is not a memory size"), std::string::npos) << bad_budget.out;
  const auto bad_halo = test::run_cli("run " + p + " --tile 64 --halo wide");
  EXPECT_EQ(bad_halo.exit_code, 2) << bad_halo.out;
  EXPECT_NE(bad_halo.out.find("--halo"), std::string::npos);
}

}  // namespace
}  // namespace terracl
