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

namespace terracl {
namespace {

// Every band's bytes, the band count and type, geotransform and CRS of a raster read through GDAL.
struct Raster {
  int w = 0, h = 0, bands = 0;
  GDALDataType type = GDT_Unknown;
  std::vector<std::vector<uint8_t>> data;
  std::array<double, 6> gt{};
  std::string crs;
  bool has_nodata = false;
  double nodata = 0;
};

Raster load(const std::string& f) {
  Raster r;
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(f.c_str(), GA_ReadOnly);
  if (!ds) {
    ADD_FAILURE() << "cannot open " << f;
    return r;
  }
  r.w = GDALGetRasterXSize(ds);
  r.h = GDALGetRasterYSize(ds);
  r.bands = GDALGetRasterCount(ds);
  GDALGetGeoTransform(ds, r.gt.data());
  r.crs = GDALGetProjectionRef(ds);
  for (int b = 1; b <= r.bands; ++b) {
    GDALRasterBandH band = GDALGetRasterBand(ds, b);
    r.type = GDALGetRasterDataType(band);
    int has = 0;
    const double nd = GDALGetRasterNoDataValue(band, &has);
    r.has_nodata = has != 0;
    r.nodata = nd;
    const int bytes = GDALGetDataTypeSizeBytes(r.type);
    std::vector<uint8_t> buf(size_t(r.w) * r.h * bytes);
    EXPECT_EQ(GDALRasterIO(band, GF_Read, 0, 0, r.w, r.h, buf.data(), r.w, r.h, r.type, 0, 0), CE_None);
    r.data.push_back(std::move(buf));
  }
  GDALClose(ds);
  return r;
}

void expect_same(const std::string& untiled, const std::string& tiled) {
  SCOPED_TRACE(tiled);
  const Raster a = load(untiled), b = load(tiled);
  ASSERT_EQ(a.w, b.w);
  ASSERT_EQ(a.h, b.h);
  ASSERT_EQ(a.bands, b.bands);
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.gt, b.gt);
  EXPECT_EQ(a.crs, b.crs);
  EXPECT_EQ(a.has_nodata, b.has_nodata);
  if (a.has_nodata && b.has_nodata) EXPECT_EQ(a.nodata, b.nodata);
  for (int k = 0; k < a.bands; ++k) {
    size_t diff = 0;
    for (size_t i = 0; i < a.data[k].size(); ++i) diff += a.data[k][i] != b.data[k][i];
    EXPECT_EQ(diff, 0u) << "band " << k + 1;
  }
}

void run(const std::string& doc, const std::string& out, int tile) {
  std::string text = doc;
  for (size_t p; (p = text.find("OUT")) != std::string::npos;) text.replace(p, 3, out);
  Pipeline p = Pipeline::parse(json::parse(text), "tiles", "tiles.json");
  p.validate();
  RunOptions ro;
  ro.device = []() -> Device& { return test::device(); };
  ro.write_resolved = false;
  RunReport r;
  if (tile == 0) return p.run(ro, r);
  TileOptions to;
  to.tile = tile;
  run_tiled(p, to, ro, r);
}

// A crop of the bundled SRTM tile (geographic), optionally with nodata holes across tile borders.
std::string dem_input(const test::TempDir& dir, int w, int h, bool holes) {
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  Heightfield t(w, h);
  t.georef = dem.georef;
  auto& gt = t.georef.geotransform;
  gt[0] += 300 * gt[1];
  gt[3] += 200 * gt[5];
  t.georef.update_metric_cell_size(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) t.at(x, y) = dem.at(300 + x, 200 + y);
  if (holes) {
    t.georef.nodata = -32768;
    for (int y = 20; y < 45; ++y)
      for (int x = 30; x < 80; ++x) t.at(x, y) = NAN;
    std::mt19937 rng(5);
    for (int k = 0; k < 100; ++k) t.at(int(rng() % w), int(rng() % h)) = NAN;
  }
  const std::string f = dir.path(holes ? "in_holes.tif" : "in.tif");
  write_heightfield(t, f);
  return f;
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
    EXPECT_EQ(load(dir.path("t/hs_edges.tif")).bands, holes ? 2 : 1);
    EXPECT_EQ(load(dir.path("t/sr.tif")).bands, holes ? 4 : 3);
    EXPECT_EQ(load(dir.path("t/hs.tif")).bands, 2);
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
  EXPECT_EQ(load(dir.path("a.tif")).bands, 2);
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
