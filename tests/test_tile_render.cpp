// SPDX-License-Identifier: Apache-2.0
// Tiled `render` against the untiled one: the same pictures (grey/RGB, with or without alpha) and
// value rasters byte for byte, on an odd-sized SRTM crop with nodata, with several tile sizes
// (tiles smaller than the 3x3 footprint included), behind a crop and a downsample.
#include <gdal.h>
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

// Every band byte for byte, band count and type, geotransform, CRS and nodata (pictures store no
// cell size or provenance).
void expect_same(const std::string& untiled, const std::string& tiled) {
  test::SameRaster what;
  what.provenance = false;
  what.items = {};
  test::expect_same_raster(untiled, tiled, what);
}

void run(const std::string& doc, const std::string& out, int tile) {
  std::string text = doc;
  for (size_t p; (p = text.find("OUT")) != std::string::npos;) text.replace(p, 3, out);
  TileOptions to;
  to.tile = tile;
  test::run_pipeline(text, tile == 0 ? nullptr : &to);
}

// A crop of the bundled SRTM tile (geographic), optionally with nodata holes across tile borders.
std::string dem_input(const test::TempDir& dir, int w, int h, bool holes) {
  return test::srtm_window(dir, holes ? "in_holes.tif" : "in.tif", w, h, 300, 200,
                           holes ? std::optional<test::Holes>(test::Holes{30, 20, 80, 45, 100, 5}) : std::nullopt);
}

const char* kRenders = R"(
  {"type": "render", "file": "OUT/hs.tif"},
  {"type": "render", "file": "OUT/hs_edges.tif", "compute_edges": true, "shading": "multidirectional"},
  {"type": "render", "file": "OUT/sr.tif", "mode": "shaded-relief"},
  {"type": "render", "file": "OUT/relief.tif", "mode": "relief", "backend": "host"},
  {"type": "render", "file": "OUT/slope.tif", "mode": "slope"},
  {"type": "render", "file": "OUT/tpi.tif", "mode": "tpi", "backend": "host"},
  {"type": "render", "file": "OUT/aspect.tif", "mode": "aspect", "compute_edges": true})";
const char* kFiles[] = {"hs.tif", "hs_edges.tif", "sr.tif", "relief.tif", "slope.tif", "tpi.tif", "aspect.tif"};

TEST(TileRender, PicturesAndValuesEqualUntiledWithAndWithoutNodata) {
  test::TempDir dir;
  for (bool holes : {false, true}) {
    const std::string in = dem_input(dir, 201, 143, holes);
    const std::string doc = "[\"" + in + "\", " + kRenders + "]";
    run(doc, dir.path("u"), 0);
    for (int tile : {64, 50, 1000}) {
      SCOPED_TRACE(testing::Message() << "tile " << tile << (holes ? " with nodata" : ""));
      run(doc, dir.path("t"), tile);
      for (const char* f : kFiles) expect_same(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f));
    }
    // The alpha band follows the whole raster: present with nodata (or gdaldem's border), else not.
    EXPECT_EQ(test::load_stored(dir.path("t/hs_edges.tif")).bands.size(), holes ? 2u : 1u);
    EXPECT_EQ(test::load_stored(dir.path("t/sr.tif")).bands.size(), holes ? 4u : 3u);
    EXPECT_EQ(test::load_stored(dir.path("t/hs.tif")).bands.size(), 2u);
  }
}

TEST(TileRender, TilesSmallerThanTheFootprintAndBehindCropAndDownsample) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 43, 31, false);  // downsample needs a complete grid
  // The render reads level 2 (after a crop and a downsample), and level 0 with one-cell tiles.
  const std::string doc = "[\"" + in + R"(", {"type": "render", "file": "OUT/a.tif", "compute_edges": true},
      {"type": "crop", "x": 7, "y": 3, "width": 33, "height": 25}, {"type": "downsample", "factor": 2},
      {"type": "render", "file": "OUT/b.tif", "mode": "shaded-relief"},
      {"type": "render", "file": "OUT/c.tif", "mode": "roughness"}, "OUT/d.tif"])";
  run(doc, dir.path("u"), 0);
  for (int tile : {3, 1}) {
    SCOPED_TRACE(testing::Message() << "tile " << tile);
    run(doc, dir.path("t"), tile);
    for (const char* f : {"a.tif", "b.tif", "c.tif", "d.tif"})
      expect_same(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f));
  }
}

TEST(TileRender, OpensTheDeviceWhenTheCallerGaveNone) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 40, 30, false);
  Pipeline p = Pipeline::parse(
      json::parse("[\"" + in + R"(", {"type": "render", "file": ")" + dir.path("a.tif") + R"("}])"), "x", "x.json");
  p.validate();
  RunOptions ro;  // no device: opened on first use, as Pipeline::run does
  ro.write_resolved = false;
  RunReport r;
  TileOptions to;
  to.tile = 16;
  run_tiled(p, to, ro, r);
  EXPECT_EQ(test::load_stored(dir.path("a.tif")).bands.size(), 2u);
}

TEST(TileRender, RefusesPngAndRampsInPercent) {
  test::TempDir dir;
  const std::string in = dem_input(dir, 40, 30, false);
  for (const auto& [stage, expect] :
       {std::pair<std::string, std::string>{R"({"type": "render", "file": "OUT/a.png"})", "use a .tif name"},
        {R"({"type": "render", "file": "OUT/a.tif", "mode": "relief", "ramp": "relative"})", "percentages"}}) {
    try {
      run("[\"" + in + "\", " + stage + "]", dir.path("t"), 16);
      ADD_FAILURE() << stage << " ran tiled";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("stage 'render'"), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("t/a.tif")));
}

}  // namespace
}  // namespace terracl
