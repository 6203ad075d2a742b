// SPDX-License-Identifier: Apache-2.0
// The tiled GeoTIFF writer compresses blocks itself (libtiff in memory, io/tiff_blocks.cpp) and
// appends them raw (TIFFWriteRawTile), so that under MPI the rank that computed a tile compresses
// it (docs/scale.md, "MPI speed-up"). Its files must hold what GDAL's own writer would: the same
// cells, georeferencing and nodata, and the very bytes GDAL compresses for each block.
#include <gdal.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cmath>
#include <fstream>
#include <terracl/io.hpp>
#include <vector>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

std::vector<uint8_t> raw_block(TIFF* t, uint32_t b) {
  std::vector<uint8_t> raw(size_t(TIFFGetStrileByteCount(t, b)));
  EXPECT_EQ(TIFFReadRawTile(t, b, raw.data(), tmsize_t(raw.size())), tmsize_t(raw.size()));
  return raw;
}

std::vector<float> cells(GDALDatasetH ds, int w, int h) {
  std::vector<float> z(size_t(w) * h);
  EXPECT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 0, w, h, z.data(), w, h, GDT_Float32, 0, 0), CE_None);
  return z;
}

}  // namespace

TEST(TileRawTiff, BlocksAreGdalsBytesAndCellsItsCells) {
  test::TempDir dir;
  // 600 x 530: 3 x 3 blocks of 256 with partial blocks on the right and bottom; nodata cells.
  const int W = 600, H = 530;
  Heightfield src = test::smooth_terrain(W, H, 30.0, 800.0, 7);
  src.georef.has_geotransform = true;
  src.georef.geotransform = {500000.0, 30.0, 0.0, 4800000.0, 0.0, -30.0};
  src.georef.nodata = -32768.0;
  for (int y = 100; y < 140; ++y)
    for (int x = 250; x < 300; ++x) src.at(x, y) = NAN;
  const std::string in = dir.path("in.tif");
  write_heightfield(src, in);

  // GDAL's writer, one process: the reference bytes (the options of the tiled writer).
  const std::string ref = dir.path("ref.tif");
  {
    std::vector<std::string> args{"-co", "TILED=YES",     "-co", "BLOCKXSIZE=256", "-co",
                                  "BLOCKYSIZE=256", "-co", "COMPRESS=DEFLATE", "-co", "PREDICTOR=3",
                                  "-co", "ZLEVEL=1"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    GDALTranslateOptions* o = GDALTranslateOptionsNew(argv.data(), nullptr);
    GDALDatasetH s = GDALOpen(in.c_str(), GA_ReadOnly);
    ASSERT_TRUE(s);
    GDALDatasetH d = GDALTranslate(ref.c_str(), s, o, nullptr);
    ASSERT_TRUE(d);
    GDALClose(d);
    GDALClose(s);
    GDALTranslateOptionsFree(o);
  }
  const std::string p = dir.path("p.json");
  std::ofstream(p) << "[\"" << in << "\", \"" << dir.path("out.tif") << "\"]";

  TIFF* r = TIFFOpen(ref.c_str(), "r");
  ASSERT_TRUE(r);
  GDALDatasetH rd = GDALOpen(ref.c_str(), GA_ReadOnly);
  const std::vector<float> want = cells(rd, W, H);
  double gt_ref[6], gt[6];
  GDALGetGeoTransform(rd, gt_ref);
  // Tiles of 256 and 512: every block whole in one tile, compressed by the tile's encoder. Tiles
  // of 37: every block gathered from several tiles, compressed when its last cell arrives.
  for (const int tile : {256, 512, 37}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    const auto res = test::run_cli("-q run " + p + " --tile " + std::to_string(tile));
    ASSERT_EQ(res.exit_code, 0) << res.out;
    const std::string out = dir.path("out.tif");
    GDALDatasetH od = GDALOpen(out.c_str(), GA_ReadOnly);
    ASSERT_TRUE(od);
    EXPECT_EQ(cells(od, W, H), want);  // bit for bit; nodata stored as -32768 in both
    int has = 0;
    EXPECT_EQ(GDALGetRasterNoDataValue(GDALGetRasterBand(od, 1), &has), -32768.0);
    EXPECT_TRUE(has);
    ASSERT_EQ(GDALGetGeoTransform(od, gt), CE_None);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(gt[i], gt_ref[i]);
    EXPECT_STREQ(GDALGetMetadataItem(od, "COMPRESSION", "IMAGE_STRUCTURE"), "DEFLATE");
    EXPECT_STREQ(GDALGetMetadataItem(od, "PREDICTOR", "IMAGE_STRUCTURE"), "3");
    EXPECT_TRUE(GDALGetMetadataItem(od, "terracl_cell_x", nullptr));
    GDALClose(od);
    TIFF* t = TIFFOpen(out.c_str(), "r");
    ASSERT_TRUE(t);
    ASSERT_EQ(TIFFNumberOfTiles(t), 9u);
    for (uint32_t b = 0; b < 9; ++b) {
      // GDAL pads a partial edge block with 0 when one write covers it and with nodata when
      // several do (the file's blocks at 37 follow the latter): compared where padding is absent.
      const bool edge = b % 3 == 2 || b / 3 == 2;
      if (tile == 37 && edge) continue;
      EXPECT_EQ(raw_block(t, b), raw_block(r, b)) << "block " << b;
    }
    TIFFClose(t);
  }
  GDALClose(rd);
  TIFFClose(r);
}
