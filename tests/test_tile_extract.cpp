// SPDX-License-Identifier: Apache-2.0
// Tiled extract (docs/scale.md, "Tiled extract"): the two-band gradient GeoTIFF written tile by
// tile equals the untiled extract bit for bit (and the untiled EXR's cells and mean elevation),
// on odd sizes and many tiles, behind a crop that leaves a nodata hole out; a raster with nodata
// is refused as untiled, leaving nothing; reconstruct of the tiled gradient equals reconstruct of
// the EXR; --resume after a killed run gives the uninterrupted file.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

namespace fs = std::filesystem;

// The metadata a gradient GeoTIFF carries besides the provenance: convention, mean, source nodata.
test::SameRaster gradient_items() {
  test::SameRaster s;
  s.items = {"terracl_cell_x", "terracl_cell_y", "terracl_gradient", "terracl_mean_elevation"};
  s.optional_items = {"terracl_height_nodata"};
  return s;
}

size_t differing_bits(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  return n;
}

TEST(TileExtract, EqualsUntiledBitForBitOnOddSizesAndManyTiles) {
  test::TempDir dir;
  // 203 x 157 (geographic): tiles of 37 (6 x 5 = 30) and 64; a crop behind which a central extract runs.
  const std::string in = test::srtm_window(dir, "in.tif", 203, 157);
  const std::string doc = R"([")" + in + R"(", "extract", "OUT/g.tif",
      {"type": "read", "filename": ")" +
                          in + R"("}, {"type": "crop", "x": 5, "y": 3, "width": 180}, "OUT/c.tif",
      {"type": "extract", "central": true}, "OUT/gc.tif"])";
  for (int tile : {37, 64}) {
    SCOPED_TRACE(tile);
    TileOptions to;
    to.tile = tile;
    test::run_untiled_and_tiled(dir, doc, to);
    test::expect_same_raster(dir.path("u/c.tif"), dir.path("t/c.tif"));
    for (const char* f : {"g.tif", "gc.tif"})
      test::expect_same_raster(dir.path(std::string("u/") + f), dir.path(std::string("t/") + f), gradient_items());
    EXPECT_EQ(test::metadata_item(dir.path("t/gc.tif"), "terracl_gradient"), "central");
    EXPECT_EQ(test::metadata_item(dir.path("t/g.tif"), "terracl_gradient"), "staggered");
  }
  // The tiled GeoTIFF holds the cells and the mean of the EXR the untiled extract writes.
  test::run_pipeline(R"([")" + in + R"(", "extract", ")" + dir.path("g.exr") + R"("])", nullptr);
  const GradientField exr = read_gradient(dir.path("g.exr")), tif = read_gradient(dir.path("t/g.tif"));
  ASSERT_EQ(exr.width, tif.width);
  ASSERT_EQ(exr.height, tif.height);
  EXPECT_EQ(differing_bits(exr.gx, tif.gx), 0u);
  EXPECT_EQ(differing_bits(exr.gy, tif.gy), 0u);
  EXPECT_EQ(exr.mean_elevation, tif.mean_elevation);
  EXPECT_GT(tif.mean_elevation, 100.0);
  EXPECT_EQ(exr.georef.geotransform, tif.georef.geotransform);
  EXPECT_EQ(exr.georef.cell_x, tif.georef.cell_x);
  EXPECT_EQ(exr.georef.cell_y, tif.georef.cell_y);
  EXPECT_TRUE(is_gradient_file(dir.path("t/g.tif")));
  EXPECT_FALSE(is_gradient_file(in));
  // A gradient GeoTIFF is not a heightfield.
  try {
    read_heightfield(dir.path("t/g.tif"));
    ADD_FAILURE() << "a gradient GeoTIFF was read as a heightfield";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is a gradient field"), std::string::npos) << e.what();
  }
}

TEST(TileExtract, NodataCropLeftOutRunsAndNodataInsideIsRefusedAsUntiled) {
  test::TempDir dir;
  // A hole at x 100..169, y 40..89 and no voids: the crop x < 95 leaves it out.
  const std::string in = test::srtm_window(dir, "in.tif", 211, 151, 300, 200, test::Holes{100, 40, 170, 90, 0, 1});
  TileOptions to;
  to.tile = 29;
  test::run_untiled_and_tiled(
      dir, R"([")" + in + R"(", {"type": "crop", "x": 0, "y": 0, "width": 95}, "extract", "OUT/g.tif"])", to);
  test::expect_same_raster(dir.path("u/g.tif"), dir.path("t/g.tif"), gradient_items());
  EXPECT_EQ(test::metadata_item(dir.path("t/g.tif"), "terracl_height_nodata"), "-32768");

  // Over the hole: the untiled message (the whole raster's count), before any tile is written.
  fs::create_directories(dir.path("x"));
  std::string untiled_error, tiled_error;
  const std::string doc = R"([")" + in + R"(", "extract", ")" + dir.path("x/g.tif") + R"("])";
  try {
    test::run_pipeline(doc, nullptr);
  } catch (const Error& e) {
    untiled_error = e.what();
  }
  try {
    test::run_pipeline(doc, &to);
  } catch (const Error& e) {
    tiled_error = e.what();
  }
  EXPECT_NE(untiled_error.find("3500 nodata/NaN cells"), std::string::npos) << untiled_error;
  EXPECT_NE(tiled_error.find(untiled_error.substr(0, untiled_error.find(';'))), std::string::npos)
      << tiled_error << "\nvs\n"
      << untiled_error;
  EXPECT_TRUE(fs::is_empty(dir.path("x")));  // no output, no temporary
}

TEST(TileExtract, ReconstructOfTheTiledGradientEqualsReconstructOfTheExr) {
  test::TempDir dir;
  const std::string in = test::srtm_window(dir, "in.tif", 131, 97, 600, 500);
  TileOptions to;
  to.tile = 24;  // 6 x 5 tiles
  test::run_pipeline(R"([")" + in + R"(", "extract", ")" + dir.path("g.tif") + R"("])", &to);
  test::run_pipeline(R"([")" + in + R"(", "extract", ")" + dir.path("g.exr") + R"("])", nullptr);
  for (const char* g : {"g.tif", "g.exr"})
    test::run_pipeline(
        R"([{"type": "reconstruct", "gradient": ")" + dir.path(g) + R"("}, ")" + dir.path(g) + R"(.r.tif"])", nullptr);
  const Heightfield a = read_heightfield(dir.path("g.exr.r.tif")), b = read_heightfield(dir.path("g.tif.r.tif"));
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(test::bit_differences(a, b), 0u);
  EXPECT_EQ(a.georef.geotransform, b.georef.geotransform);
  // A central gradient keeps its convention through a pipeline's read and write (reconstruct reads it).
  test::run_pipeline(R"([")" + in + R"(", {"type": "extract", "central": true}, ")" + dir.path("gc.tif") + R"("])", &to);
  test::run_pipeline(R"([")" + dir.path("gc.tif") + R"(", "reconstruct", ")" + dir.path("gc.r.tif") + R"("])", nullptr);
  test::run_pipeline(R"([{"type": "reconstruct", "gradient": ")" + dir.path("gc.tif") + R"("}, ")" +
                         dir.path("gc.r2.tif") + R"("])",
                     nullptr);
  EXPECT_EQ(test::bit_differences(read_heightfield(dir.path("gc.r.tif")), read_heightfield(dir.path("gc.r2.tif"))), 0u);
  // And the reconstruction is the terrain (the gradient is the terrain's, the mean kept).
  const Heightfield h = read_heightfield(in);
  double worst = 0;
  for (size_t i = 0; i < h.size(); ++i) worst = std::max(worst, std::fabs(double(h.z[i]) - b.z[i]));
  EXPECT_LT(worst, 0.5);
}

TEST(TileExtract, SubcommandTiledAndResumedAfterAKill) {
  test::TempDir dir;
  const std::string in = test::srtm_window(dir, "in.tif", 150, 121, 800, 300);
  const std::string u = dir.path("u.tif"), t = dir.path("t.tif"), r = dir.path("r.tif");
  test::run_pipeline(R"([")" + in + R"(", "extract", ")" + u + R"("])", nullptr);    // the untiled cells
  auto r2 = test::run_cli("-q extract " + in + " -o " + t + " --tile 30 --resume");  // 5 x 5 tiles
  ASSERT_EQ(r2.exit_code, 0) << r2.out;
  test::SameRaster cells = gradient_items();
  cells.provenance = false;  // a tiled subcommand records the one-stage pipeline it ran
  test::expect_same_raster(u, t, cells);
  setenv("TERRACL_TEST_KILL_AFTER_TILES", "7", 1);
  auto killed = test::run_cli("-q extract " + in + " -o " + r + " --tile 30 --resume");
  unsetenv("TERRACL_TEST_KILL_AFTER_TILES");
  EXPECT_NE(killed.exit_code, 0);
  EXPECT_FALSE(fs::exists(r));
  auto resumed = test::run_cli("extract " + in + " -o " + r + " --tile 30 --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("tiles: 18 run, 7 finished before (verified by checksum), 0 re-run"), std::string::npos)
      << resumed.out;
  test::expect_same_raster(t, r, cells);
  EXPECT_FALSE(fs::exists(r + ".journal"));
}

}  // namespace
}  // namespace terracl
