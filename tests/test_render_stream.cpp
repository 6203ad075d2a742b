// SPDX-License-Identifier: Apache-2.0
// The streamed render (render_stream.cpp): a GDAL raster read and rendered strip by
// strip writes the same file as the in-memory render (read_heightfield + render + write_image),
// for every picture mode, both backends, PNG and GeoTIFF, with nodata, percentage ramps and
// strips that do not divide the raster; progress comes once per strip.
#include <gdal_priv.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

// A float32 GeoTIFF written with GDAL alone (its geotransform when it has one, else square cells
// of cell_x), past terracl's writer checks: for files terracl itself refuses to write.
void write_unchecked_tiff(const Heightfield& h, const std::string& path) {
  GDALAllRegister();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(drv, nullptr);
  GDALDataset* ds = drv->Create(path.c_str(), h.width, h.height, 1, GDT_Float32, nullptr);
  ASSERT_NE(ds, nullptr);
  double gt[6] = {0, h.georef.cell_x, 0, 0, 0, -h.georef.cell_y};
  if (h.georef.has_geotransform) std::copy(h.georef.geotransform.begin(), h.georef.geotransform.end(), gt);
  ds->SetGeoTransform(gt);
  std::vector<float> z = h.z;
  EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, h.width, h.height, z.data(), h.width, h.height,
                                           GDT_Float32, 0, 0),
            CE_None);
  GDALClose(ds);
}

std::string bytes_of(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// The test DEM with a nodata hole and a nodata run along the right edge.
Heightfield holed() {
  Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  for (int y = 40; y < 47; ++y)
    for (int x = 30; x < 36; ++x) h.at(x, y) = NAN;
  for (int y = 70; y < 96; ++y) h.at(h.width - 1, y) = NAN;
  return h;
}

}  // namespace

TEST(RenderStream, SameFileAsTheInMemoryRender) {
  test::TempDir tmp;
  const Heightfield whole = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  Heightfield hole = holed();
  const std::string plain = tmp.path("plain.tif"), nodata = tmp.path("nodata.tif");
  write_heightfield(whole, plain);
  write_heightfield(hole, nodata);
  const Metadata meta{{"terracl:command", "render test"}};
  render::ColorRamp percent = render::ColorRamp::parse("0% 0 0 255\n50% 0 255 0\n100% 255 0 0\n", "test ramp");
  int files = 0;
  for (const std::string& in : {plain, nodata}) {
    const Heightfield h = read_heightfield(in);
    for (auto mode : {render::Mode::Hillshade, render::Mode::Relief, render::Mode::Slope, render::Mode::ShadedRelief})
      for (bool edges : {false, true})
        for (const char* ext : {".png", ".tif"}) {
          if (mode == render::Mode::Slope && std::string(ext) == ".tif") continue;  // gdaldem's float raster
          render::Options o;
          o.mode = mode;
          o.compute_edges = edges;
          if (mode == render::Mode::Relief) o.ramp = percent;
          const bool device = (files % 2) == 1;  // alternate the backends over the cases
          const std::string ref = tmp.path("ref" + std::string(ext)), got = tmp.path("got" + std::string(ext));
          render::write_image(device ? render::render(h, o, test::device()) : render::render(h, o), ref, meta);
          ASSERT_TRUE(render::can_stream_render(in, got, o));
          for (int strip : {7, 0}) {  // several strips, a short last one; the default (one strip here)
            std::filesystem::remove(got);
            render::render_file(in, got, o, device ? &test::device() : nullptr, meta, strip);
            ASSERT_EQ(bytes_of(got), bytes_of(ref))
                << in << " mode " << int(mode) << " edges " << edges << " " << ext << " strips of " << strip
                << (device ? " device" : " host");
          }
          ++files;
        }
  }
  EXPECT_EQ(files, 28);
}

// Value rasters (gdaldem's slope, aspect, TRI, TPI, roughness) streamed in strips of whole
// 256-row blocks hold the cells, nodata, units and quantity of values() + write_heightfield.
TEST(RenderStream, ValueRastersSameCellsAsInMemory) {
  test::TempDir tmp;
  Heightfield h = test::smooth_terrain(300, 600);
  h.georef.cell_x = h.georef.cell_y = 30;
  for (int y = 250; y < 262; ++y)  // a hole across the first strip boundary (row 256)
    for (int x = 40; x < 50; ++x) h.at(x, y) = NAN;
  const std::string in = tmp.path("in.tif");
  write_heightfield(h, in);
  const Heightfield src = read_heightfield(in);
  const Metadata meta{{"terracl:command", "render test"}};
  int cases = 0;
  for (auto mode : {render::Mode::Slope, render::Mode::Aspect, render::Mode::TRI, render::Mode::TPI,
                    render::Mode::Roughness})
    for (bool edges : {false, true}) {
      render::Options o;
      o.mode = mode;
      o.compute_edges = edges;
      const bool device = (cases % 2) == 1;
      Heightfield ref = device ? render::values(src, o, test::device()) : render::values(src, o);
      for (const auto& [k, v] : meta) ref.metadata[k] = v;
      write_heightfield(ref, tmp.path("ref.tif"));
      const Heightfield want = read_heightfield(tmp.path("ref.tif"));
      ASSERT_TRUE(render::can_stream_render(in, tmp.path("got.tif"), o));
      for (int strip : {256, 0}) {  // three strips (a short last one); the default (one strip)
        std::filesystem::remove(tmp.path("got.tif"));
        render::render_file(in, tmp.path("got.tif"), o, device ? &test::device() : nullptr, meta, strip);
        const Heightfield got = read_heightfield(tmp.path("got.tif"));
        const std::string what = "mode " + std::to_string(int(mode)) + " edges " + std::to_string(edges) +
                                 " strips " + std::to_string(strip) + (device ? " device" : " host");
        ASSERT_EQ(got.width, want.width) << what;
        ASSERT_EQ(got.height, want.height) << what;
        EXPECT_EQ(0, std::memcmp(got.z.data(), want.z.data(), want.z.size() * sizeof(float))) << what;
        EXPECT_EQ(got.georef.nodata, want.georef.nodata) << what;
        EXPECT_EQ(got.georef.vertical_units, want.georef.vertical_units) << what;
        EXPECT_EQ(got.georef.geotransform, want.georef.geotransform) << what;
        EXPECT_EQ(got.metadata, want.metadata) << what;
        EXPECT_EQ(stored_band_type(tmp.path("got.tif")), stored_band_type(tmp.path("ref.tif"))) << what;
      }
      ++cases;
    }
  EXPECT_EQ(cases, 10);
  EXPECT_EQ(tmp.count(), 3u) << "in.tif, ref.tif, got.tif: no temporaries left";
}

// --compress none writes value rasters uncompressed (gdaldem's layout), streamed, in memory and
// tiled, with the same cells as the DEFLATE default.
TEST(RenderStream, ValueRastersUncompressedOnRequest) {
  test::TempDir tmp;
  Heightfield h = test::smooth_terrain(300, 600);
  h.georef.cell_x = h.georef.cell_y = 30;
  const std::string in = tmp.path("in.tif");
  write_heightfield(h, in);
  auto compression = [](const std::string& path) {
    GDALAllRegister();
    std::unique_ptr<GDALDataset> ds(GDALDataset::FromHandle(GDALOpen(path.c_str(), GA_ReadOnly)));
    const char* c = ds ? ds->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE") : nullptr;
    return std::string(c ? c : "NONE");
  };
  const std::string base = "-q render " + in + " --mode aspect -o ";
  ASSERT_EQ(test::run_cli(base + tmp.path("deflate.tif")).exit_code, 0);
  ASSERT_EQ(test::run_cli(base + tmp.path("none.tif") + " --compress none").exit_code, 0);
  ASSERT_EQ(test::run_cli(base + tmp.path("tiled.tif") + " --compress none --tile 128").exit_code, 0);
  EXPECT_EQ(compression(tmp.path("deflate.tif")), "DEFLATE");
  const Heightfield want = read_heightfield(tmp.path("deflate.tif"));
  for (const char* f : {"none.tif", "tiled.tif"}) {
    EXPECT_EQ(compression(tmp.path(f)), "NONE") << f;
    const Heightfield got = read_heightfield(tmp.path(f));
    ASSERT_EQ(got.z.size(), want.z.size()) << f;
    EXPECT_EQ(0, std::memcmp(got.z.data(), want.z.data(), want.z.size() * sizeof(float))) << f;
  }
  // The in-memory path (a pipeline's render) honours it too.
  const std::string p = tmp.path("p.json");
  std::ofstream(p) << "[\"" << in << "\", {\"type\": \"render\", \"mode\": \"aspect\", \"compress\": \"none\", "
                   << "\"file\": \"" << tmp.path("piped.tif") << "\"}]";
  ASSERT_EQ(test::run_cli("-q run " + p).exit_code, 0);
  EXPECT_EQ(compression(tmp.path("piped.tif")), "NONE");
  const Heightfield piped = read_heightfield(tmp.path("piped.tif"));
  EXPECT_EQ(0, std::memcmp(piped.z.data(), want.z.data(), want.z.size() * sizeof(float)));
}

TEST(RenderStream, ProgressPerStripAndCancel) {
  test::TempDir tmp;
  const std::string in = tmp.path("in.tif");
  write_heightfield(holed(), in);
  render::Options o;
  o.compute_edges = false;  // the hillshade's layout needs no scan: one report per strip
  std::vector<std::string> messages;
  std::vector<double> fractions;
  o.progress = [&](double f, const std::string& m) {
    fractions.push_back(f);
    messages.push_back(m);
    return true;
  };
  render::render_file(in, tmp.path("a.png"), o, &test::device(), {}, 10);
  ASSERT_EQ(fractions.size(), 10u) << "96 rows in strips of 10";
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
  EXPECT_EQ(messages.back(), "strip 10/10 (rows 90..95)");
  // With compute_edges the alpha band depends on nodata anywhere: a scan pass first.
  fractions.clear();
  o.compute_edges = true;
  render::render_file(in, tmp.path("b.png"), o, nullptr, {}, 10);
  EXPECT_EQ(fractions.size(), 20u);
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
  // Cancelled half way: an error, and neither the picture nor a temporary is left.
  int calls = 0;
  o.progress = [&](double, const std::string&) { return ++calls < 15; };
  EXPECT_THROW(render::render_file(in, tmp.path("c.tif"), o, nullptr, {}, 10), Cancelled);
  EXPECT_EQ(tmp.count(), 3u) << "in.tif, a.png, b.png";
}

TEST(RenderStream, RefusesWhatItCannotStreamAndNamesBadInput) {
  test::TempDir tmp;
  render::Options o;
  EXPECT_FALSE(render::can_stream_render("x.npy", "y.png", o));
  EXPECT_FALSE(render::can_stream_render("x.png", "y.png", o)) << "16-bit PNGs take their scale from a sidecar";
  o.mode = render::Mode::TRI;
  EXPECT_TRUE(render::can_stream_render("x.tif", "y.tif", o)) << "value rasters stream too";
  EXPECT_FALSE(render::can_stream_render("x.tif", "y.png", o)) << "TRI has no picture";
  o.mode = render::Mode::Slope;
  EXPECT_TRUE(render::can_stream_render("x.tif", "y.png", o));
  EXPECT_TRUE(render::can_stream_render("x.tif", "y.tif", o)) << "slope to .tif is gdaldem's float raster";
  // An infinite cell is refused as read_heightfield refuses it, naming the file and the cell.
  Heightfield h = test::smooth_terrain(20, 30);
  h.at(3, 25) = INFINITY;
  const std::string in = tmp.path("inf.tif");
  write_unchecked_tiff(h, in);  // write_heightfield refuses infinite elevations
  try {
    render::render_file(in, tmp.path("x.png"), render::Options{}, nullptr, {}, 8);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("inf.tif: cell (3, 25)"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(tmp.path("x.png")));
  try {
    render::render_file(tmp.path("missing.tif"), tmp.path("x.png"), render::Options{}, nullptr, {}, 8);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.tif"), std::string::npos) << e.what();
  }
}

// The CLI streams `render IN.tif -o OUT` and still writes what it wrote before.
TEST(RenderStream, CliWritesTheSamePictureAsThePipelineStage) {
  test::TempDir tmp;
  const std::string in = tmp.path("in.tif");
  write_heightfield(holed(), in);
  const auto a = test::run_cli("--progress json render " + in + " -o " + tmp.path("cli.tif") + " --mode shaded-relief");
  ASSERT_EQ(a.exit_code, 0) << a.out;
  EXPECT_NE(a.out.find("\"message\": \"strip 1/1 (rows 0..95)\""), std::string::npos) << "a progress line per strip: " << a.out;
  const Heightfield h = read_heightfield(in);
  render::Options o;
  o.mode = render::Mode::ShadedRelief;
  o.compute_edges = false;
  const render::Image ref = render::render(h, o, test::device());
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::FromHandle(GDALOpen(tmp.path("cli.tif").c_str(), GA_ReadOnly)));
  ASSERT_TRUE(ds);
  ASSERT_EQ(ds->GetRasterCount(), ref.channels);
  std::vector<uint8_t> px(ref.pixels.size());
  ASSERT_EQ(ds->RasterIO(GF_Read, 0, 0, h.width, h.height, px.data(), h.width, h.height, GDT_Byte, ref.channels,
                         nullptr, ref.channels, GSpacing(ref.channels) * h.width, 1, nullptr),
            CE_None);
  EXPECT_EQ(px, ref.pixels);
  double gt[6];
  ASSERT_EQ(ds->GetGeoTransform(gt), CE_None);
  EXPECT_DOUBLE_EQ(gt[0], h.georef.geotransform[0]);
  EXPECT_DOUBLE_EQ(gt[5], h.georef.geotransform[5]);
}
