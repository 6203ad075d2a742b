// SPDX-License-Identifier: Apache-2.0
// render against the real `gdaldem` binary, pixel by pixel on a real DEM: every hillshade
// shading, slope (degrees and percent), aspect (azimuth, trigonometric, zero for flat), TRI
// (Riley, Wilson), TPI and roughness, with and without -compute_edges, on a projected crop that
// has nodata corners (so borders and nodata neighbours are both exercised), for the host
// reference and the OpenCL kernels. Then the georeferencing of `render -o x.tif`.
#include <OpenImageIO/imageio.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

/// The crop reprojected to UTM 19N at 30 m (gdalwarp, bilinear), nodata -9999 in the corners the
/// rotated grid does not cover; made once per test binary run.
const std::string& utm_dem() {
  static test::TempDir dir;
  static std::string path;
  if (path.empty()) {
    path = dir.path("utm.tif");
    const std::string cmd = "gdalwarp -q -t_srs EPSG:32619 -tr 30 30 -r bilinear -dstnodata -9999 -ot Float32 " +
                            test::data_path("crops/presidential_128x96.tif") + " " + path;
    if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << cmd;
  }
  return path;
}

struct Band {
  int w = 0, h = 0;
  std::vector<float> v;  ///< nodata -> NaN
};

Band read_band(const std::string& path, int band = 1) {
  GDALAllRegister();
  Band b;
  std::unique_ptr<GDALDataset> ds(GDALDataset::FromHandle(GDALOpen(path.c_str(), GA_ReadOnly)));
  if (!ds) return b;
  b.w = ds->GetRasterXSize();
  b.h = ds->GetRasterYSize();
  b.v.resize(size_t(b.w) * b.h);
  GDALRasterBand* rb = ds->GetRasterBand(band);
  if (rb->RasterIO(GF_Read, 0, 0, b.w, b.h, b.v.data(), b.w, b.h, GDT_Float32, 0, 0) != CE_None) return {};
  int has = 0;
  const double nd = rb->GetNoDataValue(&has);
  if (has)
    for (float& x : b.v)
      if (x == float(nd)) x = NAN;
  return b;
}

Band gdaldem(const std::string& args, const std::string& out) {
  const std::string cmd = "gdaldem " + args + " -q " + utm_dem() + " " + out;
  if (std::system(cmd.c_str()) != 0) {
    ADD_FAILURE() << cmd;
    return {};
  }
  return read_band(out);
}

struct Case {
  const char* gdaldem;  ///< utility and options
  render::Mode mode;
  void (*set)(render::Options&);
};

}  // namespace

TEST(RenderGdaldem, HillshadeShadingsMatchWithinOneGreyLevel) {
  test::TempDir tmp;
  const Heightfield h = read_heightfield(utm_dem());
  ASSERT_GT(h.count_nodata(), 100u) << "the crop must have nodata corners";
  const std::vector<Case> cases = {
      {"hillshade", render::Mode::Hillshade, [](render::Options&) {}},
      {"hillshade -z 2.5 -az 200 -alt 30", render::Mode::Hillshade,
       [](render::Options& o) { o.z_factor = 2.5, o.azimuth_deg = 200, o.altitude_deg = 30; }},
      {"hillshade -multidirectional", render::Mode::Hillshade,
       [](render::Options& o) { o.shading = render::Shading::Multidirectional; }},
      {"hillshade -combined", render::Mode::Hillshade,
       [](render::Options& o) { o.shading = render::Shading::Combined; }},
      {"hillshade -igor", render::Mode::Hillshade, [](render::Options& o) { o.shading = render::Shading::Igor; }},
      // gdaldem -alg ZevenbergenThorne and -s (issue 15's parity leftovers).
      {"hillshade -alg ZevenbergenThorne", render::Mode::Hillshade,
       [](render::Options& o) { o.gradient_alg = render::GradientAlg::ZevenbergenThorne; }},
      {"hillshade -multidirectional -alg ZevenbergenThorne", render::Mode::Hillshade,
       [](render::Options& o) {
         o.shading = render::Shading::Multidirectional, o.gradient_alg = render::GradientAlg::ZevenbergenThorne;
       }},
      {"hillshade -s 0.4 -z 2", render::Mode::Hillshade, [](render::Options& o) { o.scale = 0.4, o.z_factor = 2; }},
  };
  for (const Case& c : cases)
    for (bool edges : {false, true}) {
      const std::string args = std::string(c.gdaldem) + (edges ? " -compute_edges" : "");
      const Band ref = gdaldem(args, tmp.path("ref.tif"));
      ASSERT_EQ(ref.w, h.width) << args;
      render::Options o;
      o.mode = c.mode;
      o.compute_edges = edges;
      o.strip_rows = 17;  // several strips with halos on this small crop
      c.set(o);
      const render::Image host = render::render(h, o), dev = render::render(h, o, test::device());
      ASSERT_EQ(host.channels, 2) << "grey + alpha (nodata corners)";
      ASSERT_EQ(dev.channels, 2);
      for (const render::Image* img : {&host, &dev}) {
        int worst = 0;
        size_t alpha_mismatch = 0, differ = 0;
        for (size_t i = 0; i < h.size(); ++i) {
          const bool ref_nodata = std::isnan(ref.v[i]) || ref.v[i] == 0;  // hillshade nodata is 0
          const bool ours_nodata = img->pixels[2 * i + 1] == 0;
          if (ref_nodata != ours_nodata) {
            ++alpha_mismatch;
            continue;
          }
          if (ours_nodata) continue;
          const int d = std::abs(int(img->pixels[2 * i]) - int(ref.v[i]));
          worst = std::max(worst, d);
          differ += d != 0;
        }
        const char* which = img == &host ? " (host)" : " (device)";
        EXPECT_EQ(alpha_mismatch, 0u) << args << which;
        EXPECT_LE(worst, 1) << args << which;
        EXPECT_LT(differ, h.size() / 50) << args << which;  // off by one only where rounding ties
      }
    }
}

TEST(RenderGdaldem, ValueRastersMatchToOneInTenThousand) {
  test::TempDir tmp;
  const Heightfield h = read_heightfield(utm_dem());
  using M = render::Mode;
  const std::vector<Case> cases = {
      {"slope", M::Slope, [](render::Options&) {}},
      {"slope -p", M::Slope, [](render::Options& o) { o.slope_percent = true; }},
      {"aspect", M::Aspect, [](render::Options&) {}},
      {"aspect -trigonometric", M::Aspect, [](render::Options& o) { o.aspect_trigonometric = true; }},
      {"slope -alg ZevenbergenThorne", M::Slope,
       [](render::Options& o) { o.gradient_alg = render::GradientAlg::ZevenbergenThorne; }},
      {"slope -p -s 0.5", M::Slope, [](render::Options& o) { o.slope_percent = true, o.scale = 0.5; }},
      {"aspect -alg ZevenbergenThorne", M::Aspect,
       [](render::Options& o) { o.gradient_alg = render::GradientAlg::ZevenbergenThorne; }},
      {"TRI -alg Riley", M::TRI, [](render::Options&) {}},
      {"TRI -alg Wilson", M::TRI, [](render::Options& o) { o.tri_alg = render::TriAlg::Wilson; }},
      {"TPI", M::TPI, [](render::Options&) {}},
      {"roughness", M::Roughness, [](render::Options&) {}},
  };
  for (const Case& c : cases)
    for (bool edges : {false, true}) {
      const std::string args = std::string(c.gdaldem) + (edges ? " -compute_edges" : "");
      const Band ref = gdaldem(args, tmp.path("ref.tif"));
      ASSERT_EQ(ref.w, h.width) << args;
      render::Options o;
      o.mode = c.mode;
      o.compute_edges = edges;
      o.strip_rows = 17;
      c.set(o);
      const Heightfield host = render::values(h, o), dev = render::values(h, o, test::device());
      EXPECT_EQ(host.georef.nodata.value_or(0), -9999.0);
      for (const Heightfield* v : {&host, &dev}) {
        size_t nodata_mismatch = 0, bad = 0, valid = 0;
        double worst = 0;
        for (size_t i = 0; i < h.size(); ++i) {
          if (std::isnan(ref.v[i]) != std::isnan(v->z[i])) {
            ++nodata_mismatch;
            continue;
          }
          if (std::isnan(ref.v[i])) continue;
          ++valid;
          // 1e-4 relative; TPI is a difference of elevations (~1500 m), so its float round-off
          // is relative to the elevation: allow 1e-4 m * (1 + |z| / 1000) as well.
          const double d = std::abs(double(v->z[i]) - ref.v[i]);
          const double tol = 1e-4 * std::max(1.0, std::abs(double(ref.v[i]))) + 1e-4 * (1 + std::abs(h.z[i]) / 1000.0);
          // Aspect near north wraps between ~0 and ~360.
          const double wrapped = c.mode == M::Aspect ? std::min(d, std::abs(d - 360.0)) : d;
          worst = std::max(worst, wrapped / std::max(1.0, std::abs(double(ref.v[i]))));
          bad += wrapped > tol;
        }
        const char* which = v == &host ? " (host)" : " (device)";
        EXPECT_EQ(nodata_mismatch, 0u) << args << which;
        EXPECT_EQ(bad, 0u) << args << which << ", worst relative " << worst;
        EXPECT_GT(valid, h.size() / 2) << args;
      }
    }
}

TEST(RenderGdaldem, AspectZeroForFlatAndFlatGround) {
  // A plateau with one ramp: flat cells are nodata, or 0 with zero_for_flat; the ramp rising to
  // the east faces west (270 deg azimuth, 180 deg trigonometric).
  Heightfield h(9, 7, 100.f);
  h.georef.cell_x = h.georef.cell_y = 10;
  for (int y = 0; y < 7; ++y)
    for (int x = 5; x < 9; ++x) h.at(x, y) = 100.f + 5.f * (x - 4);
  render::Options o;
  o.mode = render::Mode::Aspect;
  for (int pass = 0; pass < 2; ++pass) {
    const Heightfield a = pass ? render::values(h, o, test::device()) : render::values(h, o);
    EXPECT_TRUE(std::isnan(a.at(2, 3)));
    EXPECT_NEAR(a.at(6, 3), 270.0, 1e-4);
  }
  o.zero_for_flat = true;
  o.aspect_trigonometric = true;
  const Heightfield b = render::values(h, o, test::device());
  EXPECT_EQ(b.at(2, 3), 0.0f);
  EXPECT_NEAR(b.at(6, 3), 180.0, 1e-4);
}

TEST(RenderGeoTiff, PictureKeepsGeoreferencingAndNodataIsTransparent) {
  GDALAllRegister();
  test::TempDir tmp;
  const std::string in = utm_dem();
  for (const char* mode : {"hillshade", "shaded-relief"}) {
    const std::string out = tmp.path(std::string(mode) + ".tif");
    const auto r = test::run_cli("-q render " + in + " -o " + out + " --mode " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    std::unique_ptr<GDALDataset> a(GDALDataset::FromHandle(GDALOpen(in.c_str(), GA_ReadOnly)));
    std::unique_ptr<GDALDataset> b(GDALDataset::FromHandle(GDALOpen(out.c_str(), GA_ReadOnly)));
    ASSERT_TRUE(a && b) << out;
    double ga[6], gb[6];
    ASSERT_EQ(a->GetGeoTransform(ga), CE_None);
    ASSERT_EQ(b->GetGeoTransform(gb), CE_None) << "the picture has no geotransform";
    for (int k = 0; k < 6; ++k) EXPECT_EQ(ga[k], gb[k]) << mode << " geotransform[" << k << "]";
    ASSERT_NE(b->GetSpatialRef(), nullptr) << "the picture has no CRS";
    EXPECT_TRUE(a->GetSpatialRef()->IsSame(b->GetSpatialRef())) << mode;
    EXPECT_EQ(b->GetRasterXSize(), a->GetRasterXSize());
    EXPECT_EQ(b->GetRasterYSize(), a->GetRasterYSize());
    const bool grey = std::string(mode) == "hillshade";
    ASSERT_EQ(b->GetRasterCount(), grey ? 2 : 4) << mode;
    GDALRasterBand* alpha = b->GetRasterBand(b->GetRasterCount());
    EXPECT_EQ(alpha->GetColorInterpretation(), GCI_AlphaBand) << mode;
    if (!grey) {
      EXPECT_EQ(b->GetRasterBand(1)->GetColorInterpretation(), GCI_RedBand);
    }
    // Alpha is 0 exactly where gdaldem writes nodata (hillshade) or on the input's nodata cells
    // (shaded relief computes its edges).
    const Band z = read_band(in), al = read_band(out, b->GetRasterCount());
    size_t mismatch = 0, transparent = 0;
    for (size_t i = 0; i < z.v.size(); ++i) {
      const int x = int(i % z.w), y = int(i / z.w);
      const bool border = x == 0 || y == 0 || x == z.w - 1 || y == z.h - 1;
      bool nodata_near = false;  // gdaldem: a nodata neighbour makes the 3x3 product nodata
      for (int j = -1; j <= 1 && !border; ++j)
        for (int k = -1; k <= 1; ++k) nodata_near |= std::isnan(z.v[size_t(y + j) * z.w + x + k]);
      const bool expect_clear = std::isnan(z.v[i]) || (grey && (border || nodata_near));
      transparent += al.v[i] == 0;
      mismatch += expect_clear != (al.v[i] == 0);
    }
    EXPECT_EQ(mismatch, 0u) << mode;
    EXPECT_GT(transparent, 100u) << mode;
  }
  // Value rasters are float32 GeoTIFFs with gdaldem's nodata, georeferenced the same way.
  const auto r = test::run_cli("-q render " + in + " -o " + tmp.path("tri.tif") + " --mode tri --tri-alg wilson");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::unique_ptr<GDALDataset> t(GDALDataset::FromHandle(GDALOpen(tmp.path("tri.tif").c_str(), GA_ReadOnly)));
  ASSERT_TRUE(t);
  EXPECT_EQ(t->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
  int has = 0;
  EXPECT_EQ(t->GetRasterBand(1)->GetNoDataValue(&has), -9999.0);
  EXPECT_TRUE(has);
  ASSERT_NE(t->GetSpatialRef(), nullptr);
  // A value mode cannot be a PNG; the error names the file and the fix.
  const auto bad = test::run_cli("-q render " + in + " -o " + tmp.path("tpi.png") + " --mode tpi");
  EXPECT_EQ(bad.exit_code, 2) << bad.out;
  EXPECT_NE(bad.out.find("tpi.png"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find(".tif"), std::string::npos) << bad.out;
}

// The CLI spells gdaldem's -alg ZevenbergenThorne and -s as --alg zevenbergenthorne --scale, with the
// same values as gdaldem; a scale that is not positive is refused naming the option.
TEST(RenderGdaldem, CliAlgAndScaleMatchGdaldem) {
  test::TempDir tmp;
  const auto r = test::run_cli("-q render " + utm_dem() + " -o " + tmp.path("s.tif") +
                               " --mode slope --alg zevenbergenthorne --scale 0.5 --compute-edges");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Band ours = read_band(tmp.path("s.tif"));
  const Band ref = gdaldem("slope -alg ZevenbergenThorne -s 0.5 -compute_edges", tmp.path("ref.tif"));
  ASSERT_EQ(ours.v.size(), ref.v.size());
  size_t bad = 0, valid = 0;
  for (size_t i = 0; i < ref.v.size(); ++i) {
    if (std::isnan(ref.v[i]) || std::isnan(ours.v[i])) {
      bad += std::isnan(ref.v[i]) != std::isnan(ours.v[i]);
      continue;
    }
    ++valid;
    bad += std::abs(ours.v[i] - ref.v[i]) > 1e-4 * std::max(1.0f, std::abs(ref.v[i]));
  }
  EXPECT_EQ(bad, 0u);
  EXPECT_GT(valid, ref.v.size() / 2);
  // Horn and the default scale give other slopes (the options are not ignored).
  const Band horn = gdaldem("slope -compute_edges", tmp.path("horn.tif"));
  size_t differ = 0;
  for (size_t i = 0; i < ref.v.size(); ++i) differ += std::abs(horn.v[i] - ours.v[i]) > 0.01f;
  EXPECT_GT(differ, valid / 2);
  const auto zero = test::run_cli("-q render " + utm_dem() + " -o " + tmp.path("z.tif") + " --mode slope --scale 0");
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.out.find("scale"), std::string::npos) << zero.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("z.tif")));
}

TEST(RenderPng, NodataIsTransparentInPng) {
  test::TempDir tmp;
  const std::string out = tmp.path("relief.png");
  const auto r = test::run_cli("-q render " + utm_dem() + " -o " + out + " --mode relief --backend host");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  auto img = OIIO::ImageInput::open(out);
  ASSERT_TRUE(img);
  const OIIO::ImageSpec& spec = img->spec();
  ASSERT_EQ(spec.nchannels, 4);
  std::vector<uint8_t> px(size_t(spec.width) * spec.height * 4);
  ASSERT_TRUE(img->read_image(0, 0, 0, 4, OIIO::TypeDesc::UINT8, px.data()));
  const Heightfield h = read_heightfield(utm_dem());
  size_t mismatch = 0;
  for (size_t i = 0; i < h.size(); ++i) mismatch += std::isnan(h.z[i]) != (px[4 * i + 3] == 0);
  EXPECT_EQ(mismatch, 0u);
}
