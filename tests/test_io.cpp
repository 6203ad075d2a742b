// SPDX-License-Identifier: Apache-2.0
// Round trips for every writable format (values, georeferencing, nodata) and reading the real
// SRTM tiles. Reference facts about the tiles come from their README (and gdalinfo).
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace terracl;

namespace {

Heightfield georeferenced_crop() { return read_heightfield(test::data_path("crops/presidential_128x96.tif")); }

void expect_same_georef(const Georef& a, const Georef& b) {
  EXPECT_EQ(a.has_geotransform, b.has_geotransform);
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(a.geotransform[i], b.geotransform[i]) << i;
  EXPECT_EQ(a.crs_wkt, b.crs_wkt);
  EXPECT_EQ(a.geographic, b.geographic);
  EXPECT_NEAR(a.cell_x, b.cell_x, 1e-9 * a.cell_x);
  EXPECT_NEAR(a.cell_y, b.cell_y, 1e-9 * a.cell_y);
}

}  // namespace

TEST(IO, ReadsSrtmHgt) {
  const Heightfield h = read_heightfield(test::data_path("dem/N44W072.hgt"));
  EXPECT_EQ(h.width, 1201);
  EXPECT_EQ(h.height, 1201);
  const HeightStats s = compute_stats(h);
  EXPECT_EQ(s.min, 115.0);
  EXPECT_EQ(s.max, 1908.0);
  EXPECT_EQ(s.nodata, 0u);
  EXPECT_TRUE(h.georef.geographic);
  EXPECT_NEAR(h.georef.geotransform[0], -72.0 - 0.5 / 1200, 1e-9);
  EXPECT_NEAR(h.georef.geotransform[3], 45.0 + 0.5 / 1200, 1e-9);
  // 3 arc-seconds at 44.5 N: about 92.6 m north-south and 66 m east-west (README of the data).
  EXPECT_NEAR(h.georef.cell_y, 92.6, 0.2);
  EXPECT_NEAR(h.georef.cell_x, 66.2, 0.3);
  ASSERT_TRUE(h.georef.nodata.has_value());
  EXPECT_EQ(*h.georef.nodata, -32768.0);
}

TEST(IO, ReadsAsciiGridAndAssumesWgs84) {
  const Heightfield h = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  EXPECT_EQ(h.width, 758);
  EXPECT_EQ(h.height, 758);
  const HeightStats s = compute_stats(h);
  EXPECT_EQ(s.min, 1547.0);
  EXPECT_EQ(s.max, 4320.0);
  EXPECT_TRUE(h.georef.geographic);
  EXPECT_NEAR(h.georef.cell_y, 92.6, 0.2);
  EXPECT_NEAR(h.georef.cell_x, 71.0, 0.3);
  EXPECT_TRUE(h.metadata.count("terracl:crs_assumed"));
}

TEST(IO, GeoTiffRoundTripExactWithGeorefAndNodata) {
  test::TempDir tmp;
  Heightfield h = georeferenced_crop();
  h.z[5] = NAN;  // a nodata cell must survive as nodata
  h.metadata["terracl:command"] = "test";
  write_heightfield(h, tmp.path("out.tif"));
  const Heightfield r = read_heightfield(tmp.path("out.tif"));
  ASSERT_EQ(r.width, h.width);
  ASSERT_EQ(r.height, h.height);
  for (size_t i = 0; i < h.size(); ++i) {
    if (i == 5)
      EXPECT_TRUE(std::isnan(r.z[i]));
    else
      ASSERT_EQ(r.z[i], h.z[i]) << i;
  }
  expect_same_georef(h.georef, r.georef);
  ASSERT_TRUE(r.georef.nodata.has_value());
  EXPECT_EQ(*r.georef.nodata, *h.georef.nodata);
  EXPECT_EQ(r.metadata.at("terracl:command"), "test");
  EXPECT_EQ(tmp.count(), 1u) << "no temporary file may remain";
}

TEST(IO, ExrRoundTripExactWithGeoref) {
  test::TempDir tmp;
  Heightfield h = georeferenced_crop();
  for (size_t i = 0; i < h.size(); ++i) h.z[i] += 0.123456f * float(i % 7);  // non-integer values
  write_heightfield(h, tmp.path("out.exr"));
  const Heightfield r = read_heightfield(tmp.path("out.exr"));
  ASSERT_EQ(r.size(), h.size());
  for (size_t i = 0; i < h.size(); ++i) ASSERT_EQ(r.z[i], h.z[i]) << i;
  expect_same_georef(h.georef, r.georef);
}

TEST(IO, Png16RoundTripWithinOneStep) {
  test::TempDir tmp;
  Heightfield h = georeferenced_crop();
  write_heightfield(h, tmp.path("out.png"));
  ASSERT_TRUE(std::filesystem::exists(tmp.path("out.png.json")));
  const Heightfield r = read_heightfield(tmp.path("out.png"));
  const HeightStats s = compute_stats(h);
  const double step = (s.max - s.min) / 65535.0;
  ASSERT_EQ(r.size(), h.size());
  for (size_t i = 0; i < h.size(); ++i) ASSERT_LE(std::fabs(r.z[i] - h.z[i]), step + 1e-4) << i;
  expect_same_georef(h.georef, r.georef);
  EXPECT_EQ(tmp.count(), 3u);  // the PNG, its JSON sidecar, its GDAL .aux.xml
}

TEST(IO, Png16IsLinearSixteenBit) {
  // Codes must be written as-is: a ramp from min to max becomes codes 0..65535 exactly.
  test::TempDir tmp;
  Heightfield h(256, 1);
  for (int x = 0; x < 256; ++x) h.at(x, 0) = float(x);
  write_heightfield(h, tmp.path("ramp.png"));
  WriteOptions wo;
  Heightfield r = read_heightfield(tmp.path("ramp.png"), ReadOptions{0.0, 65535.0, {}, {}, {}, false});
  for (int x = 0; x < 256; ++x) EXPECT_EQ(r.at(x, 0), std::round(x * 65535.0 / 255.0)) << x;
}

TEST(IO, Raw16RoundTripWithinOneStep) {
  test::TempDir tmp;
  Heightfield h = test::smooth_terrain(33, 17, 5.0);
  write_heightfield(h, tmp.path("out.r16"));
  const Heightfield r = read_heightfield(tmp.path("out.r16"));
  const HeightStats s = compute_stats(h);
  const double step = (s.max - s.min) / 65535.0;
  ASSERT_EQ(r.width, 33);
  ASSERT_EQ(r.height, 17);
  for (size_t i = 0; i < h.size(); ++i) ASSERT_LE(std::fabs(r.z[i] - h.z[i]), step + 1e-4) << i;
  EXPECT_DOUBLE_EQ(r.georef.cell_x, 5.0);
  // Little-endian: the first cell's low byte comes first.
  std::ifstream in(tmp.path("out.r16"), std::ios::binary);
  unsigned char b[2];
  in.read(reinterpret_cast<char*>(b), 2);
  const unsigned code = b[0] | (b[1] << 8);
  EXPECT_NEAR(s.min + code / 65535.0 * (s.max - s.min), h.z[0], step);
}

TEST(IO, Raw16WithOptionsInsteadOfSidecar) {
  test::TempDir tmp;
  std::vector<unsigned char> bytes = {0x00, 0x00, 0xff, 0xff, 0x00, 0x80, 0x01, 0x00};
  std::ofstream(tmp.path("x.raw"), std::ios::binary).write(reinterpret_cast<char*>(bytes.data()), 8);
  ReadOptions ro;
  ro.width = 2;
  ro.height = 2;
  ro.zmin = 100;
  ro.zmax = 100 + 65535;
  const Heightfield r = read_heightfield(tmp.path("x.raw"), ro);
  EXPECT_EQ(r.z[0], 100.f);
  EXPECT_EQ(r.z[1], 100.f + 65535.f);
  EXPECT_EQ(r.z[2], 100.f + 32768.f);
  EXPECT_EQ(r.z[3], 101.f);
}

TEST(IO, GradientExrRoundTripExact) {
  test::TempDir tmp;
  GradientField g(20, 13);
  for (size_t i = 0; i < g.size(); ++i) g.gx[i] = 0.01f * float(i), g.gy[i] = -0.003f * float(i);
  g.georef.cell_x = 30;
  g.georef.cell_y = 31;
  g.mean_elevation = 1234.5678901234;
  write_gradient(g, tmp.path("g.exr"));
  EXPECT_TRUE(is_gradient_file(tmp.path("g.exr")));
  const GradientField r = read_gradient(tmp.path("g.exr"));
  ASSERT_EQ(r.size(), g.size());
  for (size_t i = 0; i < g.size(); ++i) {
    ASSERT_EQ(r.gx[i], g.gx[i]);
    ASSERT_EQ(r.gy[i], g.gy[i]);
  }
  EXPECT_DOUBLE_EQ(r.georef.cell_x, 30);
  EXPECT_DOUBLE_EQ(r.mean_elevation, g.mean_elevation);
}

TEST(IO, HgtToGeoTiffKeepsGeotransformAndCrs) {
  test::TempDir tmp;
  const Heightfield h = read_heightfield(test::data_path("dem/N44W072.hgt"));
  write_heightfield(h, tmp.path("t.tif"));
  const Heightfield r = read_heightfield(tmp.path("t.tif"));
  expect_same_georef(h.georef, r.georef);
}

TEST(IO, NodataFillReproducesHarmonicFunctions) {
  // A plane is harmonic, so the harmonic fill of a hole in it must give the plane back.
  Heightfield h(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) h.at(x, y) = float(100 + 2.5 * x - 1.25 * y);
  const float truth = h.at(20, 15);
  for (int y = 12; y < 18; ++y)
    for (int x = 18; x < 24; ++x) h.at(x, y) = NAN;
  EXPECT_EQ(h.count_nodata(), 36u);
  EXPECT_THROW(require_finite(h, "x", "input"), Error);
  fill_nodata_harmonic(h);
  EXPECT_EQ(h.count_nodata(), 0u);
  EXPECT_NEAR(h.at(20, 15), truth, 1e-3);
  Heightfield none(3, 3, NAN);
  EXPECT_THROW(fill_nodata_harmonic(none), Error);
}

// Each bad input is a clear error naming the file; nothing is written.
TEST(IO, BadInputsAreClearErrors) {
  test::TempDir tmp;
  auto expect_error = [](const std::string& path, const std::string& needle) {
    try {
      read_heightfield(path);
      ADD_FAILURE() << "expected an error for " << path;
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
    }
  };
  expect_error(tmp.path("missing.tif"), "no such file");
  std::ofstream(tmp.path("empty.tif")).close();
  expect_error(tmp.path("empty.tif"), "empty");
  {
    std::ifstream src(test::data_path("dem/N44W072.hgt"), std::ios::binary);
    std::vector<char> buf(100000);
    src.read(buf.data(), buf.size());
    std::ofstream(tmp.path("N44W072.hgt"), std::ios::binary).write(buf.data(), buf.size());
  }
  expect_error(tmp.path("N44W072.hgt"), "truncated");
  Heightfield small(4, 4, 1.f);
  write_heightfield(small, tmp.path("p.png"));
  std::filesystem::copy_file(tmp.path("p.png"), tmp.path("renamed.tif"));
  expect_error(tmp.path("renamed.tif"), "PNG");
  std::ofstream(tmp.path("text.tif")) << "hello, I am not a raster\n";
  expect_error(tmp.path("text.tif"), "GeoTIFF");
  std::ofstream(tmp.path("text.asc")) << "hello, I am not a raster\n";
  expect_error(tmp.path("text.asc"), "ncols");
  std::ofstream(tmp.path("zero.asc")) << "ncols 0\nnrows 0\nxllcorner 0\nyllcorner 0\ncellsize 1\n";
  expect_error(tmp.path("zero.asc"), "zero.asc");
  std::ofstream(tmp.path("x.xyzzy")) << "data";
  expect_error(tmp.path("x.xyzzy"), "unknown raster extension");
  std::ofstream(tmp.path("nosize.r16"), std::ios::binary) << "abcd";
  expect_error(tmp.path("nosize.r16"), "size");
}

TEST(IO, UnwritableOutputIsClearErrorAndLeavesNothing) {
  test::TempDir tmp;
  Heightfield h(4, 4, 1.f);
  EXPECT_THROW(write_heightfield(h, tmp.path("no/such/folder/out.tif")), Error);
  EXPECT_THROW(write_heightfield(h, tmp.path("out.hgt")), Error);
  EXPECT_THROW(write_heightfield(h, tmp.path("out.unknown")), Error);
  EXPECT_EQ(tmp.count(), 0u);
}

TEST(IO, MetricCellSizeForGeographicRasters) {
  Georef g;
  g.has_geotransform = true;
  g.geographic = true;
  g.geotransform = {10.0, 1.0 / 1200, 0, 1.0, 0, -1.0 / 1200};  // centre at the equator
  g.update_metric_cell_size(1200, 2400);
  // At the equator one degree of longitude is 111.32 km and one of latitude 110.57 km (WGS84).
  EXPECT_NEAR(g.cell_x, 111319.49 / 1200, 0.01);
  EXPECT_NEAR(g.cell_y, 110574.3 / 1200, 0.05);
}

// A large void (as over SRTM lakes and shadows) in a function harmonic for the metric Laplacian
// of anisotropic cells: X^2 - Y^2 with X, Y in metres, cells 30 x 20 m. Plain sweeps over the hole
// needed tens of thousands of iterations and ignored the cell shape; the fill must be exact.
TEST(IO, NodataFillOfALargeVoidWithAnisotropicCells) {
  const int W = 260, H = 220;
  Heightfield h(W, H);
  h.georef.cell_x = 30;
  h.georef.cell_y = 20;
  auto f = [](int x, int y) { return (x * 30.0 - 3900) * (x * 30.0 - 3900) * 1e-4 - (y * 20.0 - 2200) * (y * 20.0 - 2200) * 1e-4; };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) h.at(x, y) = float(f(x, y));
  for (int y = 20; y < 200; ++y)
    for (int x = 30; x < 230; ++x)
      if (std::hypot(x - 130.0, (y - 110.0) * 1.1) < 95) h.at(x, y) = NAN;
  h.at(0, 0) = NAN;  // a corner cell, and a hole touching the border
  for (int x = 100; x < 140; ++x) h.at(x, H - 1) = NAN;
  ASSERT_GT(h.count_nodata(), 25000u);
  fill_nodata_harmonic(h);
  EXPECT_EQ(h.count_nodata(), 0u);
  double worst = 0;
  for (int y = 1; y < H - 1; ++y)  // away from the border holes (natural border condition there)
    for (int x = 1; x < W - 1; ++x) worst = std::max(worst, std::abs(h.at(x, y) - f(x, y)));
  EXPECT_LT(worst, 0.02);  // of a ~450 m range: float rounding only
  // Border holes: between their valid neighbours' values, a smooth continuation.
  EXPECT_GT(h.at(0, 0), std::min(h.at(1, 0), h.at(0, 1)) - 1.0f);
  EXPECT_LT(h.at(0, 0), std::max(h.at(1, 0), h.at(0, 1)) + 1.0f);
  for (int x = 100; x < 140; ++x) EXPECT_NEAR(h.at(x, H - 1), h.at(x, H - 2), 30.0) << x;
}
