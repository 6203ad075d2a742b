// SPDX-License-Identifier: Apache-2.0
// Tiled warp and resize (docs/scale.md, "Tiled warp"): the output grid of the whole input and
// every cell equal to the untiled run bit for bit, for each resampling, a reprojection to UTM, odd
// sizes, tiles that do not divide them, nodata, behind and before other stages, and under --resume.
#include <gdal.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

namespace fs = std::filesystem;

// Cells, georeferencing, provenance, and the items read_heightfield does not give back: the
// metric cell size and resize's engine scale.
void expect_same_raster(const std::string& untiled, const std::string& tiled, bool provenance = true) {
  test::SameRaster what;
  what.provenance = provenance;
  what.optional_items = {"engine_unreal_z_scale", "engine_unity_terrain_height_m"};
  test::expect_same_raster(untiled, tiled, what);
}

// An odd-sized crop of the SRTM tile (EPSG:4326), with a nodata hole across tile borders and
// scattered voids.
std::string dem_input(const test::TempDir& dir, int w, int h) {
  return test::srtm_window(dir, "in.tif", w, h, 300, 200, test::Holes{100, 40, 170, 90, 200, 3});
}

}  // namespace

TEST(TileWarp, ReprojectionEqualsUntiledForEveryResampling) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 211, 157);
  for (const std::string r : {"near", "bilinear", "cubic", "lanczos", "average"}) {
    // Straight from the reader, then behind a crop and before a downsample (a warp between segments).
    const std::string doc = R"([")" + in + R"(", {"type": "warp", "t_srs": "EPSG:32619", "tr": [70, 70],
        "resampling": ")" + r + R"("}, "OUT/a.tif", {"type": "crop", "x": 3, "y": 5}, {"type": "warp",
        "tr": [150, 150], "resampling": ")" + r + R"("}, "OUT/b.tif", {"type": "crop", "x": 1, "y": 2, "width": 40}, "OUT/c.tif"])";
    TileOptions to;
    to.tile = r == "near" ? 64 : 37;
    test::run_untiled_and_tiled(dir, doc, to);
    for (const char* f : {"a.tif", "b.tif", "c.tif"})
      expect_same_raster(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f));
    const Heightfield a = read_heightfield(dir.path("t/a.tif"));
    EXPECT_FALSE(a.georef.geographic) << r;
    EXPECT_GT(a.count_nodata(), 1000u) << r << ": the hole and the reprojection margins stay nodata";
  }
}

TEST(TileWarp, ResizeAndSizeEqualUntiled) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 203, 141);
  const std::string doc = R"([")" + in + R"(", {"type": "resize", "width": 517, "height": 389, "resampling": "cubic"},
      "OUT/r.tif", {"type": "warp", "ts": [99, 0], "resampling": "average"}, "OUT/s.tif",
      {"type": "resize", "preset": "unreal-505"}, "OUT/e.tif"])";
  TileOptions to;
  to.tile = 100;
  test::run_untiled_and_tiled(dir, doc, to);
  for (const char* f : {"r.tif", "s.tif", "e.tif"})
    expect_same_raster(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f));
  const Heightfield e = read_heightfield(dir.path("t/e.tif"));
  EXPECT_EQ(e.width, 505);
  GDALDatasetH ds = GDALOpen(dir.path("t/e.tif").c_str(), GA_ReadOnly);
  ASSERT_TRUE(ds);
  EXPECT_TRUE(GDALGetMetadataItem(ds, "engine_unreal_z_scale", nullptr)) << "resize records the engine Z scale";
  GDALClose(ds);
}

TEST(TileWarp, KilledRunResumesToTheUntiledOutput) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 150, 111);
  const std::string p = dir.path("p.json");
  std::ofstream(p) << R"([")" << in << R"(", {"type": "warp", "t_srs": "EPSG:32619", "tr": [60, 60],
      "resampling": "bilinear"}, ")" << dir.path("w.tif") << R"("])";
  auto u = test::run_cli("run " + p);
  ASSERT_EQ(u.exit_code, 0) << u.out;
  fs::rename(dir.path("w.tif"), dir.path("u.tif"));
  // 12 tiles of the warp's input, then the output's tiles: killed 5 tiles into the output.
  setenv("TERRACL_TEST_KILL_AFTER_TILES", "17", 1);
  auto killed = test::run_cli("run " + p + " --tile 40 --resume");
  unsetenv("TERRACL_TEST_KILL_AFTER_TILES");
  EXPECT_NE(killed.exit_code, 0) << killed.out;
  EXPECT_FALSE(fs::exists(dir.path("w.tif")));
  ASSERT_TRUE(fs::exists(dir.path("w.tif.journal")));
  auto resumed = test::run_cli("run " + p + " --tile 40 --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("5 finished before"), std::string::npos) << resumed.out;
  expect_same_raster(dir.path("u.tif"), dir.path("w.tif"));
}

TEST(TileWarp, SubcommandsTakeTile) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 140, 101);
  for (const auto& [cmd, args] : {std::pair<std::string, std::string>{"warp", "--t-srs EPSG:32619 --tr 70 70 -r cubic"},
                                  {"resize", "--size 333 257 -r lanczos"}}) {
    const std::string u = dir.path(cmd + "_u.tif"), t = dir.path(cmd + "_t.tif");
    auto r = test::run_cli(cmd + " " + in + " -o " + u + " " + args);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    r = test::run_cli(cmd + " " + in + " -o " + t + " " + args + " --tile 50");
    ASSERT_EQ(r.exit_code, 0) << r.out;
    expect_same_raster(u, t, false);
  }
  const auto bad = test::run_cli("warp " + in + " -o " + dir.path("x.tif") + " --tr 70 70 --tile 50 --fill-nodata");
  EXPECT_EQ(bad.exit_code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--fill-nodata"), std::string::npos) << bad.out;
}

TEST(TileWarp, BadOptionsNameTheStage) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 64, 64);
  Pipeline p = Pipeline::parse(
      json::parse("[\"" + in + R"(", {"type": "warp", "tr": [30]}, ")" + dir.path("o.tif") + "\"]"), "x", "x.json");
  p.validate();
  const std::string e = test::tiled_run_error(p);
  EXPECT_NE(e.find("'tr'"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(dir.path("o.tif")));
}

}  // namespace terracl
