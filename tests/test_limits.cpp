// SPDX-License-Identifier: Apache-2.0
// Limits on the numbers terracl takes (issue #32): cell sizes on every reader, band and channel
// counts, RAW16 sizes, edit-script amplitudes and operation counts. Every case is a clean error
// naming the file or JSON path, the field and the accepted range; never a NaN output.
#include <gdal_priv.h>
#include <OpenImageIO/imageio.h>

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "test_helpers.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace terracl {
namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

// A small float GeoTIFF written by GDAL itself, so that terracl's writer checks do not stop it.
void write_gdal_tiff(const std::string& path, double pixel, int bands = 1, GDALDataType type = GDT_Float32) {
  GDALAllRegister();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(drv, nullptr);
  GDALDataset* ds = drv->Create(path.c_str(), 16, 16, bands, type, nullptr);
  ASSERT_NE(ds, nullptr);
  double gt[6] = {500000, pixel, 0, 4000000, 0, -pixel};
  ds->SetGeoTransform(gt);
  std::vector<float> z(16 * 16);
  for (size_t i = 0; i < z.size(); ++i) z[i] = float(100 + (i % 16) + (i / 16));
  for (int b = 1; b <= bands; ++b)
    EXPECT_EQ(ds->GetRasterBand(b)->RasterIO(GF_Write, 0, 0, 16, 16, z.data(), 16, 16, GDT_Float32, 0, 0), CE_None);
  GDALClose(ds);
}

void expect_refused(const test::CmdResult& r, const std::vector<std::string>& words, const std::string& what) {
  EXPECT_NE(r.exit_code, 0) << what << "\n" << r.out;
  EXPECT_NE(r.out.find("terracl ERROR: "), std::string::npos) << what << "\n" << r.out;
  for (const auto& w : words) EXPECT_NE(r.out.find(w), std::string::npos) << what << ": no '" << w << "'\n" << r.out;
  EXPECT_EQ(r.out.find("internal:"), std::string::npos) << what << "\n" << r.out;
}

TEST(Limits, NonFiniteOrHugeGeoTiffCellSizesAreRefusedByEveryStage) {
  test::TempDir dir;
  for (const auto& [name, pixel] : {std::pair{"nan.tif", double(NAN)}, {"huge.tif", 1e300}, {"tiny.tif", 1e-300}}) {
    const std::string in = dir.path(name);
    write_gdal_tiff(in, pixel);
    // The reader names the file and where the cell size came from; drainage and mesh wrote NaN before.
    for (const std::string cmd : {"drainage", "mesh"}) {
      const std::string out = dir.path(cmd == "mesh" ? "o.glb" : "o.tif");
      expect_refused(test::run_cli(cmd + " -q " + q(in) + " -o " + q(out)), {name, "geotransform's pixel size", "1e+06"},
                     cmd + " " + name);
      EXPECT_FALSE(fs::exists(out)) << cmd << " " << name;
    }
    EXPECT_THROW(read_heightfield(in), Error) << name;
  }
}

TEST(Limits, SidecarAndOptionCellSizesHaveTheSameRange) {
  test::TempDir dir;
  Heightfield h = test::smooth_terrain(16, 16, 10.0);
  write_heightfield(h, dir.path("a.png"));
  json sc = json::parse(std::ifstream(dir.path("a.png.json")));
  sc["cell_x"] = 1e300;
  std::ofstream(dir.path("a.png.json")) << sc.dump();
  expect_refused(test::run_cli("info " + q(dir.path("a.png"))), {"a.png.json", "cell_x/cell_y", "1e+06"}, "sidecar 1e300");
  write_heightfield(h, dir.path("b.npy"));
  ReadOptions o;
  o.cell_size = 1e9;
  try {
    read_heightfield(dir.path("b.npy"), o);
    ADD_FAILURE() << "--cell-size 1e9 was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--cell-size"), std::string::npos) << e.what();
  }
  // Writers keep to the readers' rules, so that nothing written is refused on reading.
  h.georef.cell_x = h.georef.cell_y = 1e300;
  EXPECT_THROW(write_heightfield(h, dir.path("c.tif")), Error);
  h.georef.cell_x = h.georef.cell_y = 10;
  h.z[3] = INFINITY;
  try {
    write_heightfield(h, dir.path("d.tif"));
    ADD_FAILURE() << "an infinite elevation was written";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("d.tif"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("infinite elevation"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.path("c.tif")) || fs::exists(dir.path("d.tif")));
}

TEST(Limits, MultiBandAndComplexRastersAreRefusedNotReadAsTheirFirstBand) {
  test::TempDir dir;
  write_gdal_tiff(dir.path("rgb.tif"), 10, 3);
  expect_refused(test::run_cli("info " + q(dir.path("rgb.tif"))), {"rgb.tif", "has 3 bands", "gdal_translate -b 1"}, "rgb");
  write_gdal_tiff(dir.path("cplx.tif"), 10, 1, GDT_CFloat32);
  expect_refused(test::run_cli("info " + q(dir.path("cplx.tif"))), {"cplx.tif", "complex", "CFloat32"}, "complex");
  // An RGB EXR, through OpenImageIO.
  const std::string exr = dir.path("rgb.exr");
  {
    OIIO::ImageSpec spec(8, 8, 3, OIIO::TypeDesc::FLOAT);
    std::vector<float> px(8 * 8 * 3, 1.0f);
    auto out = OIIO::ImageOutput::create(exr);
    ASSERT_TRUE(out && out->open(exr, spec) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
  }
  expect_refused(test::run_cli("info " + q(exr)), {"rgb.exr", "has 3 channels", "single-channel"}, "rgb exr");
}

TEST(Limits, IntegerExrWithoutSidecarIsNotCalledAPng) {
  test::TempDir dir;
  const std::string exr = dir.path("u.exr");
  {
    OIIO::ImageSpec spec(8, 8, 1, OIIO::TypeDesc::UINT);
    std::vector<uint32_t> px(64, 7);
    auto out = OIIO::ImageOutput::create(exr);
    ASSERT_TRUE(out && out->open(exr, spec) && out->write_image(OIIO::TypeDesc::UINT, px.data()) && out->close());
  }
  const auto r = test::run_cli("info " + q(exr));
  EXPECT_EQ(r.out.find("PNG"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("integer EXR without a sidecar"), std::string::npos) << r.out;
}

TEST(Limits, Raw16SidecarSizesAreReportedAsGivenWithTheRange) {
  test::TempDir dir;
  std::ofstream(dir.path("a.r16"), std::ios::binary) << std::string(32, '\0');
  for (const std::string w : {"1e20", "-5", "2.5", "\"wide\""}) {
    std::ofstream(dir.path("a.r16.json")) << "{\"width\": " << w << ", \"height\": 4}";
    expect_refused(test::run_cli("info " + q(dir.path("a.r16"))), {"a.r16.json", "width", "[1, 65536]"}, "width " + w);
  }
  const auto r = test::run_cli("info " + q(dir.path("a.r16")));
  EXPECT_EQ(r.out.find("-2147483648"), std::string::npos) << r.out;
}

// Amplitudes, heights and lengths of edit operations: the JSON path (operation index and field)
// and the range, never a +-8e37 m terrain or a silent no-op.
TEST(Limits, EditAmplitudesAndLengthsAreBounded) {
  auto noise = [](double amplitude, double radius) {
    return json::array({json{{"op", "noise"}, {"center", {160, 160}}, {"radius", 100}, {"wavelength", 30}, {"amplitude", 5}},
                        json{{"op", "noise"}, {"center", {160, 160}}, {"radius", radius}, {"wavelength", 30}, {"amplitude", amplitude}}});
  };
  auto message = [](const json& script) -> std::string {
    try {
      validate_edit_script(script, 32, 32, 10.0);
    } catch (const Error& e) {
      return e.what();
    }
    return "accepted";
  };
  for (const double amp : {1e38, 1e39, -2e5}) {
    const std::string m = message(noise(amp, 100));
    EXPECT_NE(m.find("/1/amplitude"), std::string::npos) << amp << ": " << m;
    EXPECT_NE(m.find("[-100000, 100000]"), std::string::npos) << amp << ": " << m;
  }
  EXPECT_EQ(message(noise(max_edit_vertical, 100)), "accepted");
  const std::string r = message(noise(5, 1e300));
  EXPECT_NE(r.find("/1/radius"), std::string::npos) << r;
  EXPECT_NE(r.find("1e+08"), std::string::npos) << r;
  const std::string s = message(json::array({json{{"op", "erode"}, {"steps", 100001}}}));
  EXPECT_NE(s.find("/0/steps"), std::string::npos) << s;
  EXPECT_NE(s.find("100000"), std::string::npos) << s;
}

TEST(Limits, EditScriptsHoldAtMostMaxEditOperationsCountedBeforeParsing) {
  // Operations that would each be an error: the count must be refused first, and at once.
  json ops = json::array();
  for (size_t i = 0; i <= max_edit_operations; ++i) ops.push_back(json{{"op", "no_such_op"}});
  const auto t0 = std::chrono::steady_clock::now();
  try {
    validate_edit_script(json{{"operations", ops}}, 32, 32, 10.0);
    ADD_FAILURE() << "1001 operations accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/operations"), std::string::npos) << m;
    EXPECT_NE(m.find("at most 1000"), std::string::npos) << m;
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  // The CLI says the same before reading the base.
  test::TempDir dir;
  std::ofstream(dir.path("s.json")) << ops.dump();
  expect_refused(test::run_cli("edit flat:32x32@10 --script " + q(dir.path("s.json")) + " --validate"),
                 {"at most 1000 operations"}, "cli");
}

}  // namespace
}  // namespace terracl
