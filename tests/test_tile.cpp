// SPDX-License-Identifier: Apache-2.0
// Tiled (out-of-core) pipeline runs against untiled ones: the same cells bit for bit, the same
// georeferencing and provenance, on rasters with many tiles, odd sizes, nodata, a VRT mosaic and
// a global stage (fill_depressions); refusals that name the stage and the limit.
#include <gdal.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

using test::bit_differences;

// Cells, georeferencing, stored cell size and (unless told) provenance of the untiled file.
void expect_same_raster(const std::string& untiled, const std::string& tiled, bool provenance = true) {
  test::SameRaster what;
  what.provenance = provenance;
  test::expect_same_raster(untiled, tiled, what);
}

// A crop of the bundled SRTM tile (geographic: the metric cell size depends on the window), with
// nodata holes across tile borders, written as a GeoTIFF.
std::string dem_input(const test::TempDir& dir, int w, int h, bool holes) {
  return test::srtm_window(dir, holes ? "in_holes.tif" : "in.tif", w, h, 300, 200,
                           holes ? std::optional<test::Holes>(test::Holes{100, 40, 170, 90, 200, 3}) : std::nullopt);
}

TEST(Tile, LocalStagesEqualUntiledBitForBit) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 517, 389, false);
  // Writers at three levels, a crop that cuts tiles, a downsample whose blocks must align.
  const std::string doc = R"([")" + in + R"(", "OUT/a.tif",
      {"type": "crop", "x": 13, "y": 7, "width": 401, "height": 300}, "OUT/b.tif",
      {"type": "downsample", "factor": 3}, "OUT/c.tif"])";
  for (int tile : {64, 50, 1000}) {
    TileOptions to;
    to.tile = tile;
    test::run_untiled_and_tiled(dir, doc, to);
    for (const char* f : {"a.tif", "b.tif", "c.tif"})
      expect_same_raster(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f));
  }
}

TEST(Tile, NodataCarriesThroughTiles) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 301, 203, true);
  const std::string doc = R"([")" + in + R"(", {"type": "crop", "x": 5, "y": 3}, "OUT/a.tif"])";
  TileOptions to;
  to.tile = 32;
  test::run_untiled_and_tiled(dir, doc, to);
  expect_same_raster(dir.path("u/a.tif"), dir.path("t/a.tif"));
  EXPECT_GT(read_heightfield(dir.path("t/a.tif")).count_nodata(), 3000u);
}

TEST(Tile, FillDepressionsEqualsUntiledWithNodataAndOddSizes) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 301, 203, true);
  // Straight from the source (the fill reads it), and behind a crop and before a downsample (the
  // fill reads and writes temporary tiled files).
  const std::string doc = R"([")" + in + R"(", "fill_depressions", "OUT/f.tif",
      {"type": "read", "filename": ")" +
                          in + R"("}, {"type": "crop", "x": 1, "y": 2, "width": 280},
      {"type": "fill_depressions", "tag": "fill2"}, "OUT/g.tif", {"type": "fill_nodata", "tag": "skip"}])";
  TileOptions to;
  to.tile = 37;
  // fill_nodata is a global solve with no tiled form: refused before anything runs.
  try {
    test::run_untiled_and_tiled(dir, doc, to);
    FAIL() << "fill_nodata ran tiled";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("/7: stage 'skip' (fill_nodata) cannot run tiled"), std::string::npos)
        << e.what();
  }
  const std::string doc2 = doc.substr(0, doc.rfind(", {\"type\": \"fill_nodata\"")) + "]";
  test::run_untiled_and_tiled(dir, doc2, to);
  expect_same_raster(dir.path("u/f.tif"), dir.path("t/f.tif"));
  expect_same_raster(dir.path("u/g.tif"), dir.path("t/g.tif"));
  const Heightfield raw = read_heightfield(in), filled = read_heightfield(dir.path("t/f.tif"));
  size_t raised = 0;
  for (size_t i = 0; i < raw.size(); ++i) raised += filled.z[i] > raw.z[i];
  EXPECT_GT(raised, 10u);  // the test sees real depressions
  // No temporary file is left beside the outputs.
  for (const auto& e : std::filesystem::directory_iterator(dir.path("t")))
    EXPECT_EQ(e.path().extension(), ".tif") << e.path();
  const auto it = std::filesystem::directory_iterator(dir.path("t"));
  EXPECT_EQ(std::distance(std::filesystem::begin(it), std::filesystem::end(it)), 2);
}

TEST(Tile, VrtMosaicInput) {
  test::TempDir dir;
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  // Two tiles side by side, mosaicked by a VRT.
  std::vector<std::string> parts;
  for (int k = 0; k < 2; ++k) {
    Heightfield t(150, 120);
    t.georef = dem.georef;
    t.georef.geotransform[0] += (400 + 150 * k) * t.georef.geotransform[1];
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 150; ++x) t.at(x, y) = dem.at(400 + 150 * k + x, y);
    parts.push_back(dir.path("part" + std::to_string(k) + ".tif"));
    write_heightfield(t, parts.back());
  }
  const char* srcs[] = {parts[0].c_str(), parts[1].c_str()};
  int err = 0;
  GDALDatasetH vrt = GDALBuildVRT(dir.path("mosaic.vrt").c_str(), 2, nullptr, srcs, nullptr, &err);
  ASSERT_TRUE(vrt);
  GDALClose(vrt);
  const std::string doc = R"([")" + dir.path("mosaic.vrt") + R"(", "fill_depressions", "OUT/m.tif"])";
  TileOptions to;
  to.tile = 64;
  test::run_untiled_and_tiled(dir, doc, to);
  expect_same_raster(dir.path("u/m.tif"), dir.path("t/m.tif"));
  EXPECT_EQ(read_heightfield(dir.path("t/m.tif")).width, 300);
}

TEST(Tile, UntileableStagesAreRefusedNamingStageAndLimit) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 64, 64, false);
  struct Case {
    std::string stage, expect;
  };
  for (const Case& c :
       {Case{R"({"type": "erode", "delta": "d.tif"})", "/1: stage 'erode' (erode) cannot run tiled"},
        Case{R"({"type": "fill_depressions", "epsilon": true})", "epsilon"}, Case{R"("extract")", ".exr needs the whole raster"},
        Case{R"({"type": "amplify", "exemplar": ")" + in + R"("})", "learns its dictionaries in the run"},
        // Stages whose result depends on the whole raster say what (docs/scale.md).
        Case{R"({"type": "sketch", "file": ")" + dir.path("s.png") + R"("})",
             "fractions of the whole raster's cells"}}) {
    Pipeline p =
        Pipeline::parse(json::parse("[\"" + in + "\", " + c.stage + ", \"" + dir.path("o.tif") + "\"]"), "x", "x.json");
    if (c.stage == R"("extract")")  // extract tiles (to a gradient GeoTIFF); its EXR is written whole
      p = Pipeline::parse(json::parse("[\"" + in + "\", \"extract\", \"" + dir.path("o.exr") + "\"]"), "x", "x.json");
    p.validate();
    const std::string e = test::tiled_run_error<UsageError>(p);
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.stage << ": " << e;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("o.tif")));
  // Outputs that need the whole raster are refused too.
  Pipeline p = Pipeline::parse(json::parse("[\"" + in + "\", \"" + dir.path("o.png") + "\"]"), "x", "x.json");
  p.validate();
  RunReport r;
  TileOptions to;
  to.tile = 64;
  EXPECT_THROW(run_tiled(p, to, RunOptions{}, r), UsageError);
}

TEST(Tile, MemoryBudgetPicksOrRefusesATile) {
  EXPECT_EQ(parse_memory_size("512M", "x"), uint64_t(512) << 20);
  EXPECT_EQ(parse_memory_size("1.5GiB", "x"), uint64_t(1536) << 20);
  EXPECT_THROW(parse_memory_size("lots", "--memory-budget"), UsageError);
  EXPECT_THROW(parse_memory_size("-3G", "--memory-budget"), UsageError);
  test::TempDir dir;
  const std::string in = dem_input(dir, 100, 100, false);
  Pipeline p = Pipeline::parse(json::parse("[\"" + in + "\", \"" + dir.path("o.tif") + "\"]"), "x", "x.json");
  p.validate();
  RunReport r;
  TileOptions to;
  to.tile = 8192;
  to.memory_budget = 64 << 20;
  try {
    run_tiled(p, to, RunOptions{}, r);
    FAIL() << "a 8192 tile fit in 64 MiB";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("--memory-budget 64.0 MiB"), std::string::npos) << e.what();
  }
  to.tile = 0;  // picked from the budget
  run_tiled(p, to, RunOptions{}, r);
  expect_same_raster(in, dir.path("o.tif"), false);
}

}  // namespace
}  // namespace terracl
