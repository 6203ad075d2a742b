// Stages without a tiled form refuse a tiled run before anything runs, naming the stage, its JSON
// path and why (docs/scale.md, "How each stage tiles"): warp/resize, metrics and sketch.
#include <gtest/gtest.h>

#include <filesystem>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"

namespace terracl {
namespace {

TEST(TileRefusals, WarpMetricsAndSketchNameTheirLimit) {
  test::TempDir dir;
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  Heightfield t(67, 45);
  t.georef = dem.georef;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) t.at(x, y) = dem.at(x, y);
  const std::string in = dir.path("in.tif");
  write_heightfield(t, in);
  struct Case {
    std::string stage, tag, expect;
  };
  for (const Case& c : {Case{R"({"type": "warp", "t_srs": "EPSG:32619"})", "warp", "gdalwarp"},
                        Case{R"({"type": "resize", "width": 32, "height": 32})", "resize", "suggested output"},
                        Case{R"({"type": "metrics", "json": ")" + dir.path("m.json") + R"("})", "metrics",
                             "one spectrum of the raster"},
                        Case{R"({"type": "sketch", "file": ")" + dir.path("s.png") + R"("})", "sketch",
                             "fractions of the whole raster's cells"}}) {
    Pipeline p =
        Pipeline::parse(json::parse("[\"" + in + "\", " + c.stage + ", \"" + dir.path("o.tif") + "\"]"), "x", "x.json");
    p.validate();
    RunReport r;
    TileOptions to;
    to.tile = 32;
    try {
      run_tiled(p, to, RunOptions{}, r);
      ADD_FAILURE() << c.stage << " ran tiled";
    } catch (const UsageError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("x.json: /1: stage '" + c.tag + "' (" + c.tag + ") cannot run tiled"), std::string::npos)
          << what;
      EXPECT_NE(what.find(c.expect), std::string::npos) << what;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("o.tif")));
  EXPECT_FALSE(std::filesystem::exists(dir.path("m.json")));
}

}  // namespace
}  // namespace terracl
