// SPDX-License-Identifier: Apache-2.0
// Tiled amplify (docs/scale.md "Tiled amplify"): `run P.json --tile T` with an
// amplify stage gives the untiled output bit for bit - x4 and x16, odd sizes, tiles whose borders
// cut the patch grid (T f not a multiple of the spacing), behind a crop (the prepass reads through
// it), killed and resumed - and refuses what it cannot tile.
#include <gdal.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

// A w x h window of the bundled SRTM tile (geographic), optionally with a nodata hole.
std::string srtm(const test::TempDir& dir, const std::string& name, int w, int h, int x0, int y0, bool hole = false) {
  return test::srtm_window(dir, name, w, h, x0, y0,
                           hole ? std::optional<test::Holes>(test::Holes{30, 20, 41, 26, 0, 0}) : std::nullopt);
}

// One dictionary for every test (learned once: ~2 s): band-limited base, calibrated gain.
const std::string& dictionary() {
  static test::TempDir dir;
  static const std::string d = [] {
    const std::string ex = srtm(dir, "ex.tif", 160, 160, 700, 650);
    const std::string f = dir.path("d.tdic");
    const auto r = test::run_cli("dictionary learn " + ex + " -o " + f +
                                 " --atoms 48 --sparsity 1 --patch 16 --iterations 2 --constrained");
    EXPECT_EQ(r.exit_code, 0) << r.out;
    return f;
  }();
  return d;
}

void run_pipeline(const std::string& doc, const TileOptions* tiled) { test::run_pipeline(doc, tiled, "tileamp"); }

// Cells, georeferencing and the detail blend's measured correlation, gain and base.
void expect_same_cells(const std::string& untiled, const std::string& tiled) {
  test::SameRaster what;
  what.provenance = false;
  what.items = {"terracl_cell_x", "terracl_cell_y", "amplify_detail_correlation", "amplify_detail_gain",
                "amplify_base"};
  test::expect_same_raster(untiled, tiled, what);
}

std::string amplify_stage(int factor) {
  // candidates > neighbours: each patch draws its atoms by a hash of its (global) position.
  return R"({"type": "amplify", "dictionary": ")" + dictionary() + R"(", "factor": )" + std::to_string(factor) +
         R"(, "candidates": 6})";
}

TEST(TileAmplify, X4EqualsUntiledBitForBit) {
  test::TempDir dir;
  const std::string in = srtm(dir, "in.tif", 203, 151, 300, 200);
  for (const char* w : {"u", "t"}) std::filesystem::create_directories(dir.path(w));
  // Behind a crop (the prepass reads the amplify's input through it), writers before and after.
  const std::string doc = R"([")" + in + R"(", {"type": "crop", "x": 5, "y": 3, "width": 191}, "OUT/a.tif", )" +
                          amplify_stage(4) + R"(, "OUT/b.tif"])";
  auto with = [&](const char* w) {
    std::string t = doc;
    for (size_t p; (p = t.find("OUT")) != std::string::npos;) t.replace(p, 3, dir.path(w));
    return t;
  };
  run_pipeline(with("u"), nullptr);
  const Heightfield u = read_heightfield(dir.path("u/b.tif"));
  EXPECT_EQ(u.width, 191 * 4);
  // The correlation was measured (neither bound), so the prepass is what the tiles agree on.
  const double rho = std::stod(test::metadata_item(dir.path("u/b.tif"), "amplify_detail_correlation"));
  EXPECT_GT(rho, 0.0);
  EXPECT_LT(rho, 1.0);
  // 37: tile borders at 148 output cells, not a multiple of the spacing 8; 64: one aligned.
  for (int tile : {37, 64}) {
    TileOptions to;
    to.tile = tile;
    run_pipeline(with("t"), &to);
    expect_same_cells(dir.path("u/b.tif"), dir.path("t/b.tif"));
    EXPECT_EQ(test::bit_differences(read_heightfield(dir.path("u/a.tif")), read_heightfield(dir.path("t/a.tif"))), 0u);
  }
}

TEST(TileAmplify, X16CascadeEqualsUntiled) {
  test::TempDir dir;
  const std::string in = srtm(dir, "in.tif", 61, 47, 500, 300);
  const std::string doc = R"([")" + in + R"(", )" + amplify_stage(16) + R"(, "OUT"])";
  auto with = [&](const std::string& out) {
    std::string t = doc;
    t.replace(t.find("OUT"), 3, out);
    return t;
  };
  run_pipeline(with(dir.path("u.tif")), nullptr);
  TileOptions to;
  to.tile = 24;  // 3 x 2 tiles; the second step's correlation comes from a window amplified by the first
  run_pipeline(with(dir.path("t.tif")), &to);
  EXPECT_EQ(read_heightfield(dir.path("u.tif")).width, 61 * 16);
  expect_same_cells(dir.path("u.tif"), dir.path("t.tif"));
}

TEST(TileAmplify, CliTiledResumedAndNodata) {
  test::TempDir dir;
  const std::string in = srtm(dir, "in.tif", 97, 83, 200, 600);
  const std::string u = dir.path("u.tif"), t = dir.path("t.tif"), p = dir.path("p.json");
  const std::string opts = " --factor 4 --candidates 6 --dictionary " + dictionary();
  auto r = test::run_cli("amplify " + in + " -o " + u + opts);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // `amplify --tile T` is a tiled run (its work tiling is the pipeline option "tile").
  r = test::run_cli("amplify " + in + " -o " + t + opts + " --tile 30");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  expect_same_cells(u, t);
  {  // written by the tile engine: a tiled GeoTIFF (the untiled writer makes strips)
    GDALDatasetH ds = GDALOpen(t.c_str(), GA_ReadOnly);
    ASSERT_NE(ds, nullptr);
    int bx = 0, by = 0;
    GDALGetBlockSize(GDALGetRasterBand(ds, 1), &bx, &by);
    GDALClose(ds);
    EXPECT_EQ(bx, 256);
    EXPECT_EQ(by, 256);
  }
  // Killed after 5 of 12 tiles, resumed: the same cells.
  std::filesystem::remove(t);
  std::ofstream(p) << R"([")" << in << R"(", )" << amplify_stage(4) << R"(, ")" << t << R"("])";
  setenv("TERRACL_TEST_KILL_AFTER_TILES", "5", 1);
  r = test::run_cli("run " + p + " --tile 30 --resume");
  unsetenv("TERRACL_TEST_KILL_AFTER_TILES");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(t));
  r = test::run_cli("run " + p + " --tile 30 --resume");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("7 run, 5 finished before"), std::string::npos) << r.out;
  expect_same_cells(u, t);
  // Nodata: refused as untiled (amplify needs a complete grid), before any output is written.
  const std::string holes = srtm(dir, "holes.tif", 97, 83, 200, 600, true);
  for (const std::string tile : {"", " --tile 30"}) {
    r = test::run_cli("amplify " + holes + " -o " + dir.path("h.tif") + opts + tile);
    EXPECT_NE(r.exit_code, 0) << tile;
    EXPECT_NE(r.out.find("nodata/NaN cell"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(dir.path("h.tif"))) << tile;
  }
}

TEST(TileAmplify, RefusesWhatItCannotTile) {
  test::TempDir dir;
  const std::string in = srtm(dir, "in.tif", 64, 64, 0, 0);
  struct Case {
    std::string options, expect;
  };
  for (const Case& c : {Case{R"("exemplar": ")" + in + R"(")", "learns its dictionaries in the run"},
                        Case{R"("dictionary": ")" + dictionary() + R"(", "mode": "faithful")", "faithful mode"},
                        Case{R"("dictionary": ")" + dictionary() + R"(", "style_mask": ")" + in +
                                 R"(", "style_dictionary": ")" + dictionary() + R"(")",
                             "style mask"}}) {
    Pipeline p = Pipeline::parse(
        json::parse("[\"" + in + "\", {\"type\": \"amplify\", " + c.options + "}, \"" + dir.path("o.tif") + "\"]"),
        "x", "x.json");
    p.validate();
    const std::string e = test::tiled_run_error<UsageError>(p);
    EXPECT_NE(e.find("/1: stage 'amplify' (amplify) cannot run tiled"), std::string::npos) << c.options << ": " << e;
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.options << ": " << e;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("o.tif")));
}

}  // namespace
}  // namespace terracl
