// SPDX-License-Identifier: Apache-2.0
// The CLI run as a user runs it: good and bad arguments, exit codes, messages, no partial files.
#include "test_helpers.hpp"

#include <terracl/io.hpp>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

using namespace terracl;

namespace {
bool has(const std::string& s, const std::string& needle) { return s.find(needle) != std::string::npos; }
}  // namespace

TEST(CLI, Version) {
  auto r = test::run_cli("--version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_TRUE(has(r.out, "terracl 0.")) << r.out;
}

TEST(CLI, DevicesListsPocl) {
  auto r = test::run_cli("devices");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "Portable Computing Language") || has(r.out, "GPU")) << r.out;
  EXPECT_TRUE(has(r.out, "OpenCL C")) << r.out;
}

// `devices --warm` compiles ahead: with empty caches it fills PoCL's kernel cache, and a solve
// afterwards compiles nothing more (PoCL writes one .so per kernel and work-group shape it compiles).
TEST(CLI, DevicesWarmCompilesAheadOfUse) {
  test::TempDir tmp;
  auto compiled = [&] {
    size_t n = 0;
    for (const auto& e : std::filesystem::recursive_directory_iterator(tmp.dir()))
      n += e.path().extension() == ".so";
    return n;
  };
  auto saved = [](const char* name) {
    const char* v = std::getenv(name);
    return std::pair<bool, std::string>(v != nullptr, v ? v : "");
  };
  const auto xdg = saved("XDG_CACHE_HOME"), pocl = saved("POCL_CACHE_DIR");
  setenv("XDG_CACHE_HOME", tmp.dir().c_str(), 1);
  setenv("POCL_CACHE_DIR", tmp.path("pocl").c_str(), 1);
  const auto warm = test::run_cli("devices --warm");
  const size_t after_warm = compiled();
  const auto solve = test::run_cli("bench reconstruct --size 97 --repeats 1");
  const size_t after_solve = compiled();
  for (const auto& [name, v] : {std::pair{"XDG_CACHE_HOME", xdg}, std::pair{"POCL_CACHE_DIR", pocl}})
    v.first ? setenv(name, v.second.c_str(), 1) : unsetenv(name);
  EXPECT_EQ(warm.exit_code, 0) << warm.out;
  EXPECT_TRUE(has(warm.out, "warmed the kernel caches")) << warm.out;
  EXPECT_EQ(solve.exit_code, 0) << solve.out;
  if (has(warm.out, "Portable Computing Language")) {
    EXPECT_GT(after_warm, 10u);
    EXPECT_EQ(after_solve, after_warm) << "the solve compiled kernels the warm-up did not";
  }
}

TEST(CLI, InfoOnSrtmTile) {
  auto r = test::run_cli("info " + test::data_path("dem/N44W072.hgt"));
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "1201 x 1201")) << r.out;
  EXPECT_TRUE(has(r.out, "min 115.00")) << r.out;
  EXPECT_TRUE(has(r.out, "max 1908.00")) << r.out;
  EXPECT_TRUE(has(r.out, "WGS 84")) << r.out;
  auto j = test::run_cli("info --json " + test::data_path("dem/N44W072.hgt"));
  EXPECT_EQ(j.exit_code, 0);
  auto parsed = nlohmann::json::parse(j.out);
  EXPECT_EQ(parsed["width"], 1201);
  EXPECT_EQ(parsed["min"], 115.0);
}

// HGT -> GeoTIFF keeps what gdalinfo reports for the source: geotransform and CRS.
TEST(CLI, ConvertHgtToGeoTiffKeepsGeoreferencing) {
  test::TempDir tmp;
  const std::string src = test::data_path("dem/N44W072.hgt"), dst = tmp.path("n44.tif");
  auto r = test::run_cli("convert " + src + " " + dst);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  GDALAllRegister();
  GDALDataset* a = static_cast<GDALDataset*>(GDALOpen(src.c_str(), GA_ReadOnly));
  GDALDataset* b = static_cast<GDALDataset*>(GDALOpen(dst.c_str(), GA_ReadOnly));
  ASSERT_TRUE(a && b);
  double ga[6], gb[6];
  ASSERT_EQ(a->GetGeoTransform(ga), CE_None);
  ASSERT_EQ(b->GetGeoTransform(gb), CE_None);
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(ga[i], gb[i]) << i;
  ASSERT_TRUE(a->GetSpatialRef() && b->GetSpatialRef());
  EXPECT_TRUE(a->GetSpatialRef()->IsSame(b->GetSpatialRef()));
  EXPECT_EQ(b->GetRasterBand(1)->GetRasterDataType(), GDT_Int16);  // the input's type, as gdal_translate keeps it
  std::vector<float> va(1201 * 1201), vb(1201 * 1201);
  ASSERT_EQ(a->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 1201, 1201, va.data(), 1201, 1201, GDT_Float32, 0, 0), CE_None);
  ASSERT_EQ(b->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 1201, 1201, vb.data(), 1201, 1201, GDT_Float32, 0, 0), CE_None);
  EXPECT_EQ(va, vb);
  EXPECT_TRUE(has(b->GetMetadataItem("terracl_command") ? b->GetMetadataItem("terracl_command") : "", "convert"));
  GDALClose(a);
  GDALClose(b);
}

TEST(CLI, ConvertEveryFormat) {
  test::TempDir tmp;
  const std::string src = test::data_path("crops/frontrange_64.asc");
  for (const char* ext : {"tif", "exr", "png", "r16"}) {
    auto r = test::run_cli("convert " + src + " " + tmp.path(std::string("o.") + ext));
    EXPECT_EQ(r.exit_code, 0) << ext << ": " << r.out;
    auto back = test::run_cli("info " + tmp.path(std::string("o.") + ext));
    EXPECT_EQ(back.exit_code, 0) << ext << ": " << back.out;
    EXPECT_TRUE(has(back.out, "64 x 64")) << back.out;
  }
}

// Every bad input: non-zero exit, `terracl ERROR:` on stderr, and no output file left behind.
TEST(CLI, BadInputsFailCleanly) {
  test::TempDir tmp;
  const std::string out = tmp.path("out.tif");
  std::ofstream(tmp.path("empty.tif")).close();
  {
    std::ifstream src(test::data_path("dem/N44W072.hgt"), std::ios::binary);
    std::vector<char> buf(5000);
    src.read(buf.data(), buf.size());
    std::ofstream(tmp.path("N45W072.hgt"), std::ios::binary).write(buf.data(), buf.size());
  }
  ASSERT_EQ(test::run_cli("convert " + test::data_path("crops/frontrange_64.asc") + " " + tmp.path("p.png")).exit_code, 0);
  std::filesystem::copy_file(tmp.path("p.png"), tmp.path("renamed.tif"));
  std::ofstream(tmp.path("notes.tif")) << "just some text\n";
  std::ofstream(tmp.path("zero.asc")) << "ncols 0\nnrows 0\nxllcorner 0\nyllcorner 0\ncellsize 1\n";
  std::ofstream(tmp.path("noside.r16"), std::ios::binary) << "abcdefgh";
  const size_t before = tmp.count();
  const std::string good = test::data_path("crops/frontrange_64.asc");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"convert " + tmp.path("missing.tif") + " " + out, "no such file"},
      {"convert " + tmp.path("empty.tif") + " " + out, "empty"},
      {"convert " + tmp.path("N45W072.hgt") + " " + out, "truncated"},
      {"convert " + tmp.path("renamed.tif") + " " + out, "PNG"},
      {"convert " + tmp.path("notes.tif") + " " + out, "notes.tif"},
      {"convert " + tmp.path("zero.asc") + " " + out, "zero.asc"},
      {"convert " + good + " " + tmp.path("nofolder/out.tif"), "does not exist"},
      {"convert " + good + " " + tmp.path("out.xyz123"), "no GDAL driver writes rasters with the extension '.xyz123'"},
      {"convert " + tmp.path("noside.r16") + " " + out, "size"},
      {"--device 99 convert " + good + " " + out, "device index 99 does not exist"},
  };
  for (const auto& [args, needle] : cases) {
    auto r = test::run_cli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_TRUE(has(r.out, "terracl ERROR:")) << args << "\n" << r.out;
    EXPECT_TRUE(has(r.out, needle)) << args << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
    EXPECT_EQ(tmp.count(), before) << args << ": a file was left behind";
  }
}

TEST(CLI, UsageErrorsExitTwo) {
  for (const char* args : {"", "no-such-command", "info", "convert onlyone", "info --bogus-flag x.tif"}) {
    auto r = test::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << "'" << args << "': " << r.out;
    EXPECT_TRUE(has(r.out, "terracl ERROR:")) << r.out;
  }
}

TEST(CLI, DeviceChoiceByEnvironment) {
  auto r = test::run_cli("--device 0 devices");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  auto bad = test::run_cli("--device no-such-device-xyz devices");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_TRUE(has(bad.out, "no device matches")) << bad.out;
}
