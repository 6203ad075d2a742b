// SPDX-License-Identifier: Apache-2.0
// Preview rendering: hillshade against gdaldem on a real DEM, colour ramps, the render CLI.
#include <OpenImageIO/imageio.h>
#include <gdal_priv.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>
#include <terracl/version.hpp>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

std::vector<uint8_t> read_gdal_bytes(const std::string& path, int& w, int& h) {
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::FromHandle(GDALOpen(path.c_str(), GA_ReadOnly)));
  if (!ds) return {};
  w = ds->GetRasterXSize();
  h = ds->GetRasterYSize();
  std::vector<uint8_t> v(size_t(w) * h);
  if (ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, v.data(), w, h, GDT_Byte, 0, 0) != CE_None) return {};
  return v;
}

}  // namespace

TEST(RenderHillshade, MatchesGdaldemOnRealDemAwayFromBorder) {
  // The crop is geographic (SRTM, degrees). gdaldem would need one -s scale for both axes, but a
  // degree of longitude is only cos(44.3 deg) = 0.72 of a degree of latitude here, so instead we
  // give gdaldem the same DEM on a metric grid with our metric cell sizes (cell_x, cell_y): both
  // tools then shade the same surface.
  test::TempDir tmp;
  const Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  ASSERT_GT(std::abs(h.georef.cell_x - h.georef.cell_y), 10.0);  // really anisotropic in metres
  Heightfield metric = h;
  metric.georef.geographic = false;
  metric.georef.crs_wkt.clear();
  metric.georef.has_geotransform = true;
  metric.georef.geotransform = {0.0, h.georef.cell_x, 0.0, 0.0, 0.0, -h.georef.cell_y};
  const std::string dem = tmp.path("metric.tif"), out = tmp.path("gdal_hs.tif");
  write_heightfield(metric, dem);
  for (double z : {1.0, 2.5}) {
    const std::string cmd = "gdaldem hillshade -q -z " + std::to_string(z) + " " + dem + " " + out;
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    int w = 0, ht = 0;
    const std::vector<uint8_t> ref = read_gdal_bytes(out, w, ht);
    ASSERT_EQ(w, h.width);
    ASSERT_EQ(ht, h.height);
    const std::vector<uint8_t> host = render::hillshade(h, 315, 45, z);
    render::Options o;
    o.z_factor = z;
    const render::Image dev = render::render(h, o, test::device());
    ASSERT_EQ(dev.channels, 1) << "grey, no nodata: the library computes the edges by default";
    for (int backend = 0; backend < 2; ++backend) {
      int worst = 0;
      size_t differ = 0;
      for (int y = 1; y < h.height - 1; ++y)
        for (int x = 1; x < h.width - 1; ++x) {
          const size_t i = size_t(y) * w + x;
          const int ours = backend == 0 ? host[i] : dev.pixels[dev.channels * i];
          const int d = std::abs(ours - int(ref[i]));
          worst = std::max(worst, d);
          differ += d != 0;
        }
      EXPECT_LE(worst, 1) << "z factor " << z << (backend ? " device" : " host");
      EXPECT_LT(differ, size_t(w * ht / 20)) << "z factor " << z;  // off by one only rarely
    }
  }
}

TEST(RenderDevice, KernelMatchesHostForEveryMode) {
  Heightfield h = read_heightfield(test::data_path("crops/frontrange_64.asc"));
  for (int y = 30; y < 34; ++y)
    for (int x = 10; x < 13; ++x) h.at(x, y) = NAN;  // nodata colour and border handling
  for (auto mode : {render::Mode::Hillshade, render::Mode::Relief, render::Mode::Slope, render::Mode::ShadedRelief}) {
    render::Options o;
    o.mode = mode;
    o.z_factor = 1.5;
    o.ramp = render::ColorRamp::parse("nv 9 8 7\n0% 0 0 255\n2600 0 255 0\n100% 255 0 0\n", "test ramp");
    const render::Image a = render::render(h, o), b = render::render(h, o, test::device());
    ASSERT_EQ(a.pixels.size(), b.pixels.size());
    int worst = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) worst = std::max(worst, std::abs(int(a.pixels[i]) - int(b.pixels[i])));
    EXPECT_LE(worst, 1) << "mode " << int(mode);
    EXPECT_EQ(b.channels, a.channels);
    const bool grey = mode == render::Mode::Hillshade || mode == render::Mode::Slope;
    ASSERT_EQ(b.channels, grey ? 2 : 4) << "alpha for the nodata cells";
    const size_t nd = size_t(31) * 64 + 11;
    EXPECT_EQ(b.pixels[b.channels * nd + b.channels - 1], 0) << "nodata is transparent";
    EXPECT_EQ(b.pixels[b.channels * (nd + 20) + b.channels - 1], 255) << "valid cells are opaque";
    if (mode == render::Mode::Relief) EXPECT_EQ(b.pixels[b.channels * nd], 9);  // nodata colour
  }
}

TEST(RenderHillshade, FlatGroundAndFacingSlopes) {
  Heightfield flat(8, 8, 50.f);
  flat.georef.cell_x = flat.georef.cell_y = 30;
  for (uint8_t v : render::hillshade(flat)) EXPECT_EQ(v, 181);  // 1 + 254 sin 45 = 180.6
  // A 45-degree slope facing the north-west sun is fully lit: 1 + 254 = 255.
  Heightfield nw(8, 8);
  nw.georef.cell_x = nw.georef.cell_y = 1;
  const double g = 1.0 / std::sqrt(2.0);  // |gradient| = 1 towards the north-west
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) nw.at(x, y) = float(g * x + g * y);
  EXPECT_EQ(render::hillshade(nw)[size_t(4) * 8 + 4], 255);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) nw.at(x, y) = float(-10 * (x + y));  // steep, facing away
  EXPECT_EQ(render::hillshade(nw)[size_t(4) * 8 + 4], 1);
}

TEST(RenderRamp, GdaldemFormatWithPercentagesAndNodata) {
  const auto r =
      render::ColorRamp::parse("# comment\n0% 0 0 0\n100 200,100,0\n50%:100 100 100\n nv 1 2 3\n", "ramp.txt");
  uint8_t c[3];
  r.color(0, 0, 400, c);  // 0 %
  EXPECT_EQ(c[0], 0);
  r.color(150, 0, 400, c);  // between 100 m (200,100,0) and 50 % = 200 m (100,100,100)
  EXPECT_EQ(c[0], 150);
  EXPECT_EQ(c[1], 100);
  EXPECT_EQ(c[2], 50);
  r.color(1000, 0, 400, c);  // beyond the last entry
  EXPECT_EQ(c[0], 100);
  r.color(NAN, 0, 400, c);
  EXPECT_EQ(c[0], 1);
  EXPECT_EQ(c[2], 3);
  try {
    render::ColorRamp::parse("0 0 0 0\n10 300 0 0\n", "bad.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(render::ColorRamp::parse("# nothing\n", "empty.txt"), Error);
  EXPECT_THROW(render::ColorRamp::parse("high 1 2 3\n", "word.txt"), Error);
  // The default ramp is in metres, whatever the data range: the sea below 0 m is blue, the coast
  // green, a 500 m plateau is not snow (the issue: a percent ramp made it white), 4500 m is snow.
  const auto d = render::ColorRamp::default_ramp();
  d.color(-50, -100, 500, c);
  EXPECT_GT(c[2], c[1]);
  EXPECT_GT(c[2], c[0]);
  d.color(0, -100, 500, c);
  EXPECT_GT(c[1], c[0]);
  EXPECT_GT(c[1], c[2]);
  d.color(500, 0, 500, c);
  EXPECT_LT(std::min({c[0], c[1], c[2]}), 200);
  d.color(4500, 0, 4500, c);
  EXPECT_GE(c[0], 240);
  // Named ramps; the former percent ramp is "relative" (highest value near white).
  render::ColorRamp::from_spec("relative").color(1, 0, 1, c);
  EXPECT_GE(c[0], 240);
  render::ColorRamp::from_spec("grey").color(0.5, 0, 1, c);
  EXPECT_EQ(c[0], c[1]);
  try {
    render::ColorRamp::from_spec("no-such-ramp");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-ramp"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("hypsometric"), std::string::npos) << e.what();
  }
}

TEST(RenderCli, WritesEightBitPngForEveryMode) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/frontrange_64.asc");
  {
    std::ofstream f(tmp.path("ramp.txt"));
    f << "0% 0 0 255\n100% 255 0 0\n";
  }
  for (const char* mode : {"hillshade", "relief", "slope", "shaded-relief"}) {
    const std::string out = tmp.path(std::string(mode) + ".png");
    // Both backends through the CLI (the host one skips the OpenCL start-up, keeping this quick).
    const std::string backend = std::string(mode).find("shade") != std::string::npos ? "device" : "host";
    const auto r = test::run_cli("-q render " + in + " -o " + out + " --mode " + mode + " --ramp " +
                                 tmp.path("ramp.txt") + " --backend " + backend);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    auto img = OIIO::ImageInput::open(out);
    ASSERT_TRUE(img) << out;
    const OIIO::ImageSpec& spec = img->spec();
    EXPECT_EQ(spec.width, 64);
    EXPECT_EQ(spec.height, 64);
    // Grey pictures carry alpha for gdaldem's nodata border (no --compute-edges); the colour
    // ones are RGB (this DEM has no nodata).
    const bool grey = std::string(mode) == "hillshade" || std::string(mode) == "slope";
    EXPECT_EQ(spec.nchannels, grey ? 2 : 3) << mode;
    EXPECT_EQ(spec.format, OIIO::TypeDesc::UINT8);
    EXPECT_EQ(spec.get_string_attribute("terracl:version"), terracl::version()) << "provenance in the PNG";
    EXPECT_NE(spec.get_string_attribute("terracl:command").find("render"), std::string::npos);
    std::vector<uint8_t> px(size_t(64) * 64 * spec.nchannels);
    ASSERT_TRUE(img->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, px.data()));
    std::vector<uint8_t> first;  // channel 0 of the interior: not a blank picture
    for (int y = 1; y < 63; ++y)
      for (int x = 1; x < 63; ++x) first.push_back(px[(size_t(y) * 64 + x) * spec.nchannels]);
    const auto [lo, hi] = std::minmax_element(first.begin(), first.end());
    EXPECT_LT(*lo, *hi) << mode;
  }
  EXPECT_EQ(tmp.count(), 5u);  // four pictures and the ramp: no heightfield, no temporaries
  const auto bad = test::run_cli("-q render " + in + " -o " + tmp.path("x.png") + " --mode glow");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("glow"), std::string::npos) << bad.out;
  const auto noramp =
      test::run_cli("-q render " + in + " -o " + tmp.path("x.png") + " --ramp " + tmp.path("missing.txt"));
  EXPECT_NE(noramp.exit_code, 0);
  EXPECT_NE(noramp.out.find("missing.txt"), std::string::npos) << noramp.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("x.png")));
}

// gdaldem color-relief's colour names ("2600 white", optionally with an alpha): each one gives
// the colour gdaldem itself paints for it (its own table: grey is 191, brown 191 127 63).
TEST(RenderRamp, GdaldemColourNamesGiveGdaldemsColours) {
  test::TempDir tmp;
  // A copy: GDAL leaves a .aux.xml beside the ASCII grid it reads, which must not land in data/.
  const std::string in = tmp.path("dem.tif");
  ASSERT_EQ(std::system(("gdal_translate -q " + test::data_path("crops/frontrange_64.asc") + " " + in).c_str()), 0);
  GDALAllRegister();
  for (const char* name : {"white", "black", "red", "green", "blue", "yellow", "magenta", "cyan", "aqua", "grey", "gray",
                           "orange", "brown", "purple", "violet", "indigo"}) {
    const std::string ramp = tmp.path(std::string(name) + ".txt"), out = tmp.path(std::string(name) + ".tif");
    std::ofstream(ramp) << "0% " << name << "\n100% " << name << " 255\n";
    ASSERT_EQ(std::system(("gdaldem color-relief -q " + in + " " + ramp + " " + out).c_str()), 0) << name;
    std::unique_ptr<GDALDataset> ds(GDALDataset::FromHandle(GDALOpen(out.c_str(), GA_ReadOnly)));
    ASSERT_TRUE(ds) << out;
    const auto r = render::ColorRamp::load(ramp);
    uint8_t c[3];
    r.color(1500, 1000, 2000, c);
    for (int k = 0; k < 3; ++k) {
      uint8_t g = 0;
      ASSERT_EQ(ds->GetRasterBand(k + 1)->RasterIO(GF_Read, 32, 32, 1, 1, &g, 1, 1, GDT_Byte, 0, 0), CE_None);
      EXPECT_EQ(int(c[k]), int(g)) << name << " channel " << k;
    }
  }
  try {
    render::ColorRamp::parse("0 chartreuse\n", "names.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("names.txt:1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("colour-name"), std::string::npos) << e.what();
  }
  EXPECT_THROW(render::ColorRamp::parse("0 white 300\n", "alpha.txt"), Error);
}

// `edit --preview` draws the shaded relief at the output's full size with the chosen ramp; a bad
// ramp is refused before any work, leaving no output.
TEST(RenderCli, EditPreviewIsFullSizeAndTakesARamp) {
  test::TempDir tmp;
  {
    std::ofstream f(tmp.path("s.json"));
    f << R"({"units": "cells", "operations": [{"op": "free_crest", "points": [[5, 20], [60, 30]], "height": 40}]})";
  }
  const std::string base = "flat:67x41@10 --script " + tmp.path("s.json");
  const auto bad = test::run_cli("-q edit " + base + " -o " + tmp.path("a.tif") + " --preview " + tmp.path("a.png") +
                                 " --ramp no-such-ramp");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("no-such-ramp"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("a.tif")));
  const auto ok = test::run_cli("-q edit " + base + " -o " + tmp.path("b.tif") + " --preview " + tmp.path("b.png") +
                                " --ramp grey");
  ASSERT_EQ(ok.exit_code, 0) << ok.out;
  auto in = OIIO::ImageInput::open(tmp.path("b.png"));
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().width, 67);
  EXPECT_EQ(in->spec().height, 41);
}

// The device path works strip by strip (bounded device memory) and reports progress per strip;
// the strips' halos make the picture identical to one launch over the whole grid.
TEST(RenderDevice, StripsReportProgressAndMatchOneLaunch) {
  const Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  for (auto mode : {render::Mode::Hillshade, render::Mode::ShadedRelief, render::Mode::TRI}) {
    render::Options o;
    o.mode = mode;
    o.compute_edges = false;
    std::vector<double> fractions;
    o.strip_rows = 10;
    o.progress = [&](double f, const std::string&) {
      fractions.push_back(f);
      return true;
    };
    render::Options whole = o;
    whole.strip_rows = h.height;
    whole.progress = nullptr;
    if (mode == render::Mode::TRI) {
      const Heightfield a = render::values(h, o, test::device()), b = render::values(h, whole, test::device());
      for (size_t i = 0; i < h.size(); ++i)
        ASSERT_TRUE(a.z[i] == b.z[i] || (std::isnan(a.z[i]) && std::isnan(b.z[i]))) << i;
    } else {
      const render::Image a = render::render(h, o, test::device()), b = render::render(h, whole, test::device());
      EXPECT_EQ(a.pixels, b.pixels) << int(mode);
    }
    ASSERT_EQ(fractions.size(), 10u) << "96 rows in strips of 10";
    EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
    EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
    // Cancelling through the callback stops the render with an error.
    o.progress = [](double, const std::string&) { return false; };
    if (mode == render::Mode::TRI) {
      EXPECT_THROW(render::values(h, o, test::device()), Cancelled);
    } else {
      EXPECT_THROW(render::render(h, o, test::device()), Cancelled);
    }
  }
}
