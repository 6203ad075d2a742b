// SPDX-License-Identifier: Apache-2.0
// `--tile N [--halo] [--memory-budget]` on subcommands (render, convert, downsample, erode; every
// heightfield -> heightfield stage has the flags): the same one-stage pipeline through the tile runner, the same cells as
// the untiled command; flags a tiled run cannot honour are refused.
#include <gdal.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <terracl/io.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

std::string input(const test::TempDir& dir) {
  return test::srtm_window(dir, "in.tif", 157, 111, 400, 500);
}

size_t differing_cells(const std::string& a, const std::string& b) {
  const Heightfield u = read_heightfield(a), t = read_heightfield(b);
  if (u.width != t.width || u.height != t.height) return size_t(-1);
  size_t n = 0;
  for (size_t i = 0; i < u.size(); ++i)
    n += std::isnan(u.z[i]) != std::isnan(t.z[i]) || (!std::isnan(u.z[i]) && std::memcmp(&u.z[i], &t.z[i], 4) != 0);
  return n;
}

// Bytes of every band of a picture (GDAL), with its size and band count in front.
std::vector<uint8_t> picture(const std::string& f) {
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(f.c_str(), GA_ReadOnly);
  if (!ds) return {};
  const int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds), n = GDALGetRasterCount(ds);
  std::vector<uint8_t> out{uint8_t(w), uint8_t(h), uint8_t(n)};
  std::vector<uint8_t> band(size_t(w) * h);
  for (int b = 1; b <= n; ++b) {
    EXPECT_EQ(GDALRasterIO(GDALGetRasterBand(ds, b), GF_Read, 0, 0, w, h, band.data(), w, h, GDT_Byte, 0, 0), CE_None);
    out.insert(out.end(), band.begin(), band.end());
  }
  GDALClose(ds);
  return out;
}

void expect_ok(const test::CmdResult& r) { EXPECT_EQ(r.exit_code, 0) << r.out; }

TEST(TileSubcommands, EqualTheUntiledCommands) {
  test::TempDir dir;
  const std::string in = input(dir);
  const std::string u = dir.path("u_"), t = dir.path("t_");
  struct Case {
    std::string command, file, options;
  };
  // Each CLI start costs about a second: one command per kind of stage (the pipeline tests cover the rest).
  expect_ok(test::run_cli("-q downsample " + in + " -o " + u + "d.tif --factor 3"));
  expect_ok(test::run_cli("-q downsample " + in + " -o " + t + "d.tif --factor 3 --tile 40"));
  EXPECT_EQ(differing_cells(u + "d.tif", t + "d.tif"), 0u);
  expect_ok(test::run_cli("-q convert " + in + " " + t + "conv.tif --tile 64 --memory-budget 64M"));
  EXPECT_EQ(differing_cells(in, t + "conv.tif"), 0u);
  // render writes its own file (-o is its --file). A render that streams just streams under --tile
  // (to a .png too, which a tiled run cannot write).
  expect_ok(test::run_cli("-q render " + in + " -o " + u + "r.tif --mode shaded-relief"));
  const auto streamed = test::run_cli("render " + in + " -o " + t + "r.tif --mode shaded-relief --tile 33");
  expect_ok(streamed);
  EXPECT_NE(streamed.out.find("streams strip by strip; --tile is not needed"), std::string::npos) << streamed.out;
  const auto a = picture(u + "r.tif");
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(a == picture(t + "r.tif"));
  expect_ok(test::run_cli("-q render " + in + " -o " + u + "r.png"));
  expect_ok(test::run_cli("-q render " + in + " -o " + t + "r.png --tile 33"));
  EXPECT_TRUE(picture(u + "r.png") == picture(t + "r.png"));
  // erode: a halo of one cell per sub-step (not bit for bit; close).
  expect_ok(test::run_cli("-q erode " + in + " -o " + u + "e.tif --steps 8"));
  expect_ok(test::run_cli("-q erode " + in + " -o " + t + "e.tif --steps 8 --tile 48 --halo 2"));
  const Heightfield eu = read_heightfield(u + "e.tif"), et = read_heightfield(t + "e.tif");
  ASSERT_EQ(eu.size(), et.size());
  for (size_t i = 0; i < eu.size(); ++i) ASSERT_NEAR(eu.z[i], et.z[i], 1e-3) << i;
}

TEST(TileSubcommands, RefuseWhatATiledRunCannotDo) {
  test::TempDir dir;
  const std::string in = input(dir);
  struct Case {
    std::string args, expect;
  };
  for (const Case& c :
       {Case{"render " + in + " -o " + dir.path("a.png") + " --tile 32 --resume", "use a .tif name"},
        Case{"downsample " + in + " -o " + dir.path("a.tif") + " --factor 2 --tile 32 --cog", "--cog"},
        Case{"erode " + in + " -o " + dir.path("a.tif") + " --halo 3", "--halo needs --tile"},
        Case{"convert " + in + " " + dir.path("a.tif") + " --tile 32 --zmin 3", "--zmin"},
        // The tile engine's refusals name the command the user ran, not `run`.
        Case{"erode " + in + " -o " + dir.path("a.tif") + " --tile 4096 --memory-budget 1M",
             "terracl ERROR: erode: --memory-budget 1.0 MiB: a 4096 x 4096 tile needs"},
        Case{"extract " + in + " -o " + dir.path("a.exr") + " --tile 32", "terracl ERROR: extract: terracl extract: /2"}}) {
    const auto r = test::run_cli(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.args << "\n" << r.out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("a.tif")));
  EXPECT_FALSE(std::filesystem::exists(dir.path("a.png")));
  EXPECT_FALSE(std::filesystem::exists(dir.path("a.exr")));
}

}  // namespace
}  // namespace terracl
