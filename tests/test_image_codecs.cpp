// SPDX-License-Identifier: Apache-2.0
// terracl's PNG (libpng) and EXR (OpenEXR) codecs against OpenImageIO, an independent reader and
// writer of both formats: what one writes the other reads, cell for cell and attribute for
// attribute; and the CLI's start-up loads no image-library plugin stack.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

namespace terracl {
namespace {

template <class T>
void oiio_write(const std::string& path, OIIO::ImageSpec spec, OIIO::TypeDesc type, const std::vector<T>& px) {
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) && out->write_image(type, px.data()) && out->close()) << path;
}

Heightfield ramp(int w, int h) {
  Heightfield f(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) f.at(x, y) = float(100.0 + 3.25 * x - 1.5 * y + 0.125 * ((x * y) % 7));
  f.georef.cell_x = f.georef.cell_y = 30.0;
  return f;
}

TEST(ImageCodecs, Png16WrittenByTerraclReadsTheSameCodesInOpenImageIO) {
  test::TempDir dir;
  const Heightfield h = ramp(37, 23);
  WriteOptions o;
  o.zmin = 0.0;
  o.zmax = 655.35;  // one code per centimetre
  write_heightfield(h, dir.path("h.png"), o);
  auto in = OIIO::ImageInput::open(dir.path("h.png"));
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  ASSERT_EQ(spec.width, 37);
  ASSERT_EQ(spec.height, 23);
  ASSERT_EQ(spec.nchannels, 1);
  EXPECT_EQ(spec.format, OIIO::TypeDesc::UINT16);
  EXPECT_NEAR(spec.get_float_attribute("oiio:Gamma", 0.0f), 1.0f, 1e-6) << "a linear PNG (gAMA 1.0)";
  std::vector<uint16_t> codes(h.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT16, codes.data()));
  for (size_t i = 0; i < h.size(); ++i) ASSERT_NEAR(codes[i] * 0.01, h.z[i], 0.00501) << i;
  const Heightfield back = read_heightfield(dir.path("h.png"));
  for (size_t i = 0; i < h.size(); ++i) ASSERT_NEAR(back.z[i], h.z[i], 0.005 + 1e-4) << i;
}

TEST(ImageCodecs, PngLayoutsWrittenByOpenImageIOAreRead) {
  test::TempDir dir;
  const int w = 19, h = 11;
  // 8-bit grey: codes 0..255 as they are.
  std::vector<uint8_t> grey(size_t(w) * h);
  for (size_t i = 0; i < grey.size(); ++i) grey[i] = uint8_t((i * 7) % 256);
  oiio_write(dir.path("g8.png"), OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::UINT8), OIIO::TypeDesc::UINT8, grey);
  ReadOptions ro;
  ro.zmin = 0.0;
  ro.zmax = 255.0;
  const Heightfield g8 = read_heightfield(dir.path("g8.png"), ro);
  for (size_t i = 0; i < grey.size(); ++i) ASSERT_FLOAT_EQ(g8.z[i], float(grey[i])) << i;
  // 16-bit grey + alpha: the grey channel, not premultiplied by the alpha.
  std::vector<uint16_t> ga(size_t(w) * h * 2);
  for (size_t i = 0; i < size_t(w) * h; ++i) ga[2 * i] = uint16_t(1000 + 37 * i), ga[2 * i + 1] = i % 3 ? 65535 : 0;
  OIIO::ImageSpec spec(w, h, 2, OIIO::TypeDesc::UINT16);
  spec.alpha_channel = 1;
  spec.attribute("oiio:UnassociatedAlpha", 1);
  oiio_write(dir.path("ga.png"), spec, OIIO::TypeDesc::UINT16, ga);
  ro.zmax = 65535.0;
  const Heightfield g16 = read_heightfield(dir.path("ga.png"), ro);
  for (size_t i = 0; i < size_t(w) * h; ++i) ASSERT_FLOAT_EQ(g16.z[i], float(ga[2 * i])) << i;
  // RGB is refused with the way out.
  std::vector<uint8_t> rgb(size_t(w) * h * 3, 9);
  oiio_write(dir.path("rgb.png"), OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::UINT8), OIIO::TypeDesc::UINT8, rgb);
  try {
    read_heightfield(dir.path("rgb.png"), ro);
    FAIL() << "an RGB PNG was read as elevation";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("has 3 channels"), std::string::npos) << e.what();
  }
}

TEST(ImageCodecs, TruncatedPngIsAnErrorNamingTheFile) {
  test::TempDir dir;
  write_heightfield(ramp(64, 64), dir.path("t.png"));
  std::ifstream in(dir.path("t.png"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir.path("cut.png"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(dir.path("cut.png.json")) << std::ifstream(dir.path("t.png.json")).rdbuf();
  try {
    read_heightfield(dir.path("cut.png"));
    FAIL() << "a truncated PNG was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.png"), std::string::npos) << e.what();
  }
}

TEST(ImageCodecs, HalfExrWithAnOffsetDataWindowIsRead) {
  test::TempDir dir;
  const int w = 13, h = 9;
  OIIO::ImageSpec spec(w, h, 1, OIIO::TypeDesc::HALF);
  spec.x = 5;
  spec.y = -3;
  spec.full_x = 0;
  spec.full_y = 0;
  spec.channelnames = {"Y"};
  std::vector<float> z(size_t(w) * h);
  for (size_t i = 0; i < z.size(); ++i) z[i] = float(i) * 0.5f - 7.0f;  // exact in half
  oiio_write(dir.path("h.exr"), spec, OIIO::TypeDesc::FLOAT, z);
  ReadOptions ro;
  ro.cell_size = 1.0;
  const Heightfield f = read_heightfield(dir.path("h.exr"), ro);
  ASSERT_EQ(f.width, w);
  ASSERT_EQ(f.height, h);
  for (size_t i = 0; i < z.size(); ++i) ASSERT_EQ(f.z[i], z[i]) << i;
}

TEST(ImageCodecs, ExrWrittenByTerraclCarriesItsAttributesForOpenImageIO) {
  test::TempDir dir;
  Heightfield h = ramp(21, 17);
  h.georef.has_geotransform = true;
  h.georef.geotransform = {500000.0, 30.0, 0.0, 4950000.0, 0.0, -30.0};
  h.metadata["terracl:note"] = "ridge \xc3\xa9t\xc3\xa9";
  h.metadata["terracl:cell_x"] = "30";  // the same name as a float attribute of ours
  h.metadata["compression"] = "none";   // the name of an attribute every EXR header has
  write_heightfield(h, dir.path("h.exr"));
  auto in = OIIO::ImageInput::open(dir.path("h.exr"));
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
  EXPECT_EQ(spec.get_string_attribute("compression"), "zip");
  EXPECT_NEAR(spec.get_float_attribute("terracl:cell_x"), 30.0f, 1e-6);
  EXPECT_EQ(spec.get_string_attribute("terracl:note"), "ridge \xc3\xa9t\xc3\xa9");
  EXPECT_NE(spec.get_string_attribute("terracl:georef").find("4950000"), std::string::npos);
  std::vector<float> z(h.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, z.data()));
  EXPECT_EQ(z, h.z);
  const Heightfield back = read_heightfield(dir.path("h.exr"));
  EXPECT_EQ(back.z, h.z);
  EXPECT_EQ(back.georef.geotransform, h.georef.geotransform);
  EXPECT_EQ(back.metadata.at("terracl:note"), "ridge \xc3\xa9t\xc3\xa9");
}

TEST(ImageCodecs, GradientExrWrittenByOpenImageIOInEitherChannelOrderIsRead) {
  test::TempDir dir;
  const int w = 8, h = 6;
  std::vector<float> px(size_t(w) * h * 2);
  for (size_t i = 0; i < size_t(w) * h; ++i) px[2 * i] = float(i), px[2 * i + 1] = -float(i) * 0.25f;
  OIIO::ImageSpec spec(w, h, 2, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"gy", "gx"};  // stored alphabetically (gx first) whatever the order given
  oiio_write(dir.path("g.exr"), spec, OIIO::TypeDesc::FLOAT, px);
  ASSERT_TRUE(is_gradient_file(dir.path("g.exr")));
  const GradientField g = read_gradient(dir.path("g.exr"));
  for (size_t i = 0; i < g.size(); ++i) {
    ASSERT_EQ(g.gy[i], float(i)) << i;
    ASSERT_EQ(g.gx[i], -float(i) * 0.25f) << i;
  }
}

TEST(ImageCodecs, PictureTextChunksSurviveUtf8AndInvalidKeywords) {
  test::TempDir dir;
  render::Image img;
  img.width = 4;
  img.height = 3;
  img.channels = 3;
  img.pixels.assign(size_t(4) * 3 * 3, 200);
  render::write_image(img, dir.path("p.png"), {{"terracl:command", "terracl render \xc3\xa9.tif"}, {"  two  spaces  ", "x"}});
  auto in = OIIO::ImageInput::open(dir.path("p.png"));
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().get_string_attribute("terracl:command"), "terracl render \xc3\xa9.tif");
  EXPECT_EQ(in->spec().get_string_attribute("two spaces"), "x");
  std::vector<uint8_t> px(img.pixels.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data()));
  EXPECT_EQ(px, img.pixels);
}

std::string command_output(const char* command) {
  std::string out;
  if (FILE* p = popen(command, "r")) {
    char buf[4096];
    while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
    pclose(p);
  }
  return out;
}

// Each shared library is loaded and relocated at every start: the CLI must not pull a general
// image library's plugin set (codecs, video, DICOM, X11) to read PNG and EXR.
TEST(ImageCodecs, TheCliLoadsNoImageLibraryPluginStack) {
  const std::string out = command_output("ldd " TERRACL_CLI " 2>&1");
  ASSERT_NE(out.find("libpng"), std::string::npos) << out;
  for (const char* lib : {"libOpenImageIO", "libavcodec", "libopencv", "libgdcm", "libopenvdb"})
    EXPECT_EQ(out.find(lib), std::string::npos) << lib << " is loaded at start-up";
#if TERRACL_LAZY_LIBRARIES
  // GDAL and libtiff come at the first call into them (cmake/LazyLibraries.cmake)...
  EXPECT_EQ(out.find("libgdal"), std::string::npos) << out;
  EXPECT_EQ(out.find("libtiff"), std::string::npos) << out;
#endif
}

#if TERRACL_LAZY_LIBRARIES
// ...and then work as if linked: a GeoTIFF round trip through the CLI, GDAL's error messages
// (a variadic CPLError path) included, and a command that opens no raster loads neither.
TEST(ImageCodecs, LazilyLoadedGdalWorksFromTheFirstCall) {
  test::TempDir dir;
  write_heightfield(ramp(33, 21), dir.path("a.png"));
  const auto conv = test::run_cli("-q convert " + dir.path("a.png") + " " + dir.path("a.tif"));
  ASSERT_EQ(conv.exit_code, 0) << conv.out;
  EXPECT_EQ(read_heightfield(dir.path("a.tif")).z, read_heightfield(dir.path("a.png")).z);
  std::ofstream(dir.path("bad.tif")) << "II*\0 this is not a TIFF";
  const auto bad = test::run_cli("info " + dir.path("bad.tif"));
  EXPECT_EQ(bad.exit_code, 1) << bad.out;
  EXPECT_NE(bad.out.find("bad.tif"), std::string::npos) << bad.out;
  EXPECT_EQ(command_output("LD_DEBUG=files " TERRACL_CLI " --version 2>&1").find("libgdal"), std::string::npos);
}
#endif

}  // namespace
}  // namespace terracl
