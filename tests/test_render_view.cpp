// SPDX-License-Identifier: Apache-2.0
// The perspective picture (render --mode perspective): analytic horizon and Lambert
// brightness on a flat plane, left-right symmetry, occlusion, nodata holes, kernel against the
// host reference, and the CLI's option errors. Small grids and pictures: well under 2 s in all.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

constexpr double kDeg = M_PI / 180.0;

Heightfield plane(int w, int h, double cell) {
  Heightfield p(w, h);
  p.georef.cell_x = p.georef.cell_y = cell;
  std::fill(p.z.begin(), p.z.end(), 0.0f);
  return p;
}

const uint8_t* px(const render::Image& img, int x, int y) { return &img.pixels[(size_t(y) * img.width + x) * 3]; }

// Sky and haze are bluish; the test ramps are grey, so a grey pixel is terrain.
bool is_grey(const uint8_t* p) { return p[0] == p[1] && p[1] == p[2]; }

// Looking north (view azimuth 180) down by `elev` at the world point (x, y, z) from `dist` metres
// away, so that the centre pixel of an odd-sized picture looks exactly at it.
void aim(render::Options& o, double x, double y, double z, double elev, double dist) {
  o.view.azimuth_deg = 180;
  o.view.elevation_deg = elev;
  o.view.has_eye = true;
  o.view.eye[0] = x;
  o.view.eye[1] = y + dist * std::cos(elev * kDeg);
  o.view.eye[2] = z + dist * std::sin(elev * kDeg);
}

}  // namespace

// A flat plane seen from 5 m above its south edge: the sky starts at the row where the ray to the
// plane's far edge (38 km away, 0.0075 deg below the horizon) lands, which is the horizon's row
// tan(e) / tan(vfov / 2) above the centre; below it every pixel has Lambert's brightness.
TEST(RenderView, FlatPlaneHorizonRowAndLambertBrightness) {
  const Heightfield h = plane(129, 129, 300);
  const double far = 128 * 300.0 - 1;
  for (double elev : {6.0, 10.0}) {
    for (double alt : {30.0, 60.0}) {
      render::Options o;
      o.mode = render::Mode::Perspective;
      o.ramp = render::ColorRamp::parse("-1 200 200 200\n1 200 200 200\n", "test ramp");
      o.view.width = 96, o.view.height = 64, o.view.fov_deg = 40, o.view.haze = 0;
      o.altitude_deg = alt, o.azimuth_deg = 100;
      o.view.azimuth_deg = 180, o.view.elevation_deg = elev, o.view.has_eye = true;
      o.view.eye[0] = 64 * 300.0, o.view.eye[1] = far, o.view.eye[2] = 5;
      const render::Image img = render::render(h, o);
      ASSERT_EQ(img.width, 96);
      ASSERT_EQ(img.channels, 3);
      const double ty = std::tan(20 * kDeg) * 64 / 96;
      const double horizon_row = (1 - std::tan(elev * kDeg) / ty) * 32 - 0.5;
      const double dip = std::atan(5.0 / far);
      const double edge_sy = std::tan(elev * kDeg - dip) / ty;
      const int first = int(std::floor((1 - edge_sy) * 32 - 0.5)) + 1;  // first row whose centre is below the edge
      EXPECT_NEAR(first, horizon_row, 1.0) << "the far edge is at the horizon";
      ASSERT_TRUE(first >= 1 && first < 60) << first;
      const double lambert = 200 * (0.3 + 0.8 * std::sin(alt * kDeg));
      for (int x : {0, 30, 47, 95}) {
        EXPECT_FALSE(is_grey(px(img, x, first - 1))) << "sky above the horizon, column " << x << " elev " << elev;
        for (int y = first; y < 64; ++y) {
          const uint8_t* p = px(img, x, y);
          ASSERT_TRUE(is_grey(p)) << "plane at (" << x << ", " << y << "), elev " << elev << " first " << first << " rgb " << int(p[0]) << " " << int(p[1]) << " " << int(p[2]);
          if (y >= first + 2) EXPECT_NEAR(p[0], lambert, 1.0) << "Lambert at (" << x << ", " << y << ")";
        }
      }
    }
  }
}

// A terrain mirror-symmetric about the column through its centre, seen from the south with the sun
// in the north: the picture is its own mirror image.
TEST(RenderView, SymmetricTerrainGivesSymmetricPicture) {
  Heightfield h(65, 49);
  h.georef.cell_x = h.georef.cell_y = 20;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const double dx = std::abs(x - 32), dy = y - 20;
      h.at(x, y) = float(400 * std::exp(-(dx * dx + dy * dy) / 120.0) + 60 * std::cos(dx * 0.4) * std::sin(y * 0.3));
    }
  render::Options o;
  o.mode = render::Mode::Perspective;
  o.view.width = 120, o.view.height = 80, o.view.azimuth_deg = 180, o.view.elevation_deg = 25;
  o.azimuth_deg = 0, o.altitude_deg = 35;
  const render::Image img = render::render(h, o);
  size_t same = 0, terrain = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t *a = px(img, x, y), *b = px(img, img.width - 1 - x, y);
      int d = 0;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a[c]) - int(b[c])));
      same += d <= 1;
      terrain += a[2] < 200;  // not sky or haze
    }
  EXPECT_GE(same, size_t(0.999 * img.width * img.height));
  EXPECT_GT(terrain, size_t(img.width * img.height / 4)) << "the terrain fills the frame";
}

// The centre pixel looks at a blue plateau; a red 2000 m column on the line of sight hides it.
// Through a nodata hole the background (sky colour) shows.
TEST(RenderView, ColumnOccludesAndNodataShowsBackground) {
  Heightfield h = plane(65, 65, 10);
  for (int y = 10; y <= 14; ++y)
    for (int x = 30; x <= 34; ++x) h.at(x, y) = 50;
  render::Options o;
  o.mode = render::Mode::Perspective;
  o.ramp = render::ColorRamp::parse("-1 128 128 128\n25 128 128 128\n40 0 0 255\n60 0 0 255\n80 255 0 0\n", "ramp");
  o.view.width = o.view.height = 33;
  o.view.haze = 0;
  o.azimuth_deg = 180, o.altitude_deg = 45;
  aim(o, 320, 120, 50, 20, 400);
  auto centre = [&](const Heightfield& g, Device* dev) {
    const render::Image img = dev ? render::render(g, o, *dev) : render::render(g, o);
    const uint8_t* p = px(img, 16, 16);
    return std::array<int, 3>{p[0], p[1], p[2]};
  };
  for (Device* dev : {static_cast<Device*>(nullptr), &test::device()}) {
    const auto seen = centre(h, dev);
    EXPECT_GT(seen[2], 100);
    EXPECT_EQ(seen[0], 0) << "the plateau is blue";
    Heightfield blocked = h;
    // The line of sight passes (320, 308, 118) half way: a column of 3 x 2 cells there.
    for (int y = 30; y <= 31; ++y)
      for (int x = 31; x <= 33; ++x) blocked.at(x, y) = 2000;
    const auto hidden = centre(blocked, dev);
    EXPECT_GT(hidden[0], 60) << "the column is red";
    EXPECT_EQ(hidden[2], 0);
    Heightfield holed = h;
    for (int y = 8; y <= 16; ++y)
      for (int x = 28; x <= 36; ++x) holed.at(x, y) = NAN;
    const auto bg = centre(holed, dev);
    // Looking down through the hole: the sky's horizon colour (214, 226, 236).
    EXPECT_EQ(bg, (std::array<int, 3>{214, 226, 236}));
  }
}

// Kernel against the host reference on a real DEM crop with a nodata patch and the default framed
// camera (shadows, haze): per-pixel difference <= 2 of 255 on >= 99.9 % of pixels.
TEST(RenderView, DeviceMatchesHostReference) {
  Heightfield h = read_heightfield(test::data_path("crops/frontrange_64.asc"));
  for (int y = 20; y < 26; ++y)
    for (int x = 40; x < 47; ++x) h.at(x, y) = NAN;
  render::Options o;
  o.mode = render::Mode::Perspective;
  o.view.width = 200, o.view.height = 125;
  o.z_factor = 1.5;
  o.azimuth_deg = 250, o.altitude_deg = 25;
  const render::Image a = render::render_view(h, o), b = render::render_view(h, o, test::device());
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  size_t ok = 0, terrain = 0;
  const size_t n = size_t(a.width) * a.height;
  for (size_t i = 0; i < n; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a.pixels[3 * i + c]) - int(b.pixels[3 * i + c])));
    ok += d <= 2;
    terrain += a.pixels[3 * i + 2] < 200;
  }
  EXPECT_GE(ok, size_t(std::ceil(0.999 * n))) << n - ok << " pixels differ by more than 2";
  EXPECT_GT(terrain, n / 3);
}

// The kernel and the host reference agree with the natural material and a lake (water level at the
// crop's mean elevation): rock, grass, snow, shore, water body and glint in one picture.
TEST(RenderView, DeviceMatchesHostWithWaterAndNaturalMaterial) {
  const Heightfield h = read_heightfield(test::data_path("crops/frontrange_64.asc"));
  render::Options o;
  o.mode = render::Mode::Perspective;
  o.view.width = 160, o.view.height = 100;
  o.view.material = render::Material::Natural;
  o.view.has_water_level = true, o.view.water_level = 3530;
  o.azimuth_deg = 20, o.altitude_deg = 30;  // the sun ahead of the camera (view azimuth 200): glint
  const render::Image a = render::render_view(h, o), b = render::render_view(h, o, test::device());
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  size_t ok = 0, water = 0, glint = 0;
  const size_t n = size_t(a.width) * a.height;
  for (size_t i = 0; i < n; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a.pixels[3 * i + c]) - int(b.pixels[3 * i + c])));
    ok += d <= 2;
    water += a.pixels[3 * i + 2] > a.pixels[3 * i] + 30 && a.pixels[3 * i + 2] < 200;  // blue, not sky
    glint += a.pixels[3 * i] > 245 && a.pixels[3 * i + 1] > 245;
  }
  EXPECT_GE(ok, size_t(std::ceil(0.999 * n))) << n - ok << " pixels differ by more than 2";
  EXPECT_GT(water, n / 10) << "the lake covers part of the picture";
  EXPECT_GT(glint, 0u) << "the sun's glint";
}

// A flat floor D metres under the water, seen at elevation e: the centre pixel is Schlick's Fresnel
// F = 0.02 + 0.98 (1 - sin e)^5 mixing the sky at sqrt(sin e) of the way to the zenith with the
// body: the Lambert-lit floor through exp(-L / (c, 2.5 c, 5 c)), L = D / sin e, over the deep
// colour (22, 74, 100) lit by 0.3 + 0.8 sin(alt). The sun stands off the mirror direction (no glint).
TEST(RenderView, WaterOverFlatFloorHasBeerLambertAndFresnelColour) {
  const double e = 30, alt = 45, clarity = 10;
  for (double depth : {4.0, 30.0}) {
    Heightfield h = plane(65, 65, 10);
    std::fill(h.z.begin(), h.z.end(), float(-depth));
    render::Options o;
    o.mode = render::Mode::Perspective;
    o.ramp = render::ColorRamp::parse("-1000 200 180 160\n1000 200 180 160\n", "test ramp");
    o.view.width = o.view.height = 33;
    o.view.haze = 0;
    o.view.has_water_level = true, o.view.water_level = 0;
    o.view.water_clarity = clarity;
    o.azimuth_deg = 90, o.altitude_deg = alt;
    aim(o, 320, 320, 0, e, 500);
    const double se = std::sin(e * kDeg), lit = 0.3 + 0.8 * std::sin(alt * kDeg);
    const double fr = 0.02 + 0.98 * std::pow(1 - se, 5), L = depth / se;
    const double floor_rgb[3] = {200, 180, 160}, deep[3] = {22, 74, 100}, ext[3] = {clarity, 2.5 * clarity, 5 * clarity};
    const double hor[3] = {214, 226, 236}, zen[3] = {112, 152, 204};
    for (Device* dev : {static_cast<Device*>(nullptr), &test::device()}) {
      const render::Image img = dev ? render::render(h, o, *dev) : render::render(h, o);
      const uint8_t* p = px(img, 16, 16);
      for (int c = 0; c < 3; ++c) {
        const double t = std::exp(-L / ext[c]);
        const double body = floor_rgb[c] * lit * t + deep[c] * lit * (1 - t);
        const double want = (1 - fr) * body + fr * (hor[c] + std::sqrt(se) * (zen[c] - hor[c]));
        EXPECT_NEAR(p[c], want, 1.0) << "channel " << c << " depth " << depth << (dev ? " device" : " host");
      }
    }
  }
}

// Water at or below the lowest cell changes nothing (host and device, byte for byte); nor does
// the automatic sea level on a terrain wholly above 0 m.
TEST(RenderView, TerrainAboveTheWaterIsUnchanged) {
  const Heightfield h = read_heightfield(test::data_path("crops/frontrange_64.asc"));  // 2971..4320 m
  render::Options o;
  o.mode = render::Mode::Perspective;
  o.view.width = 64, o.view.height = 40;
  o.view.material = render::Material::Natural;
  for (Device* dev : {static_cast<Device*>(nullptr), &test::device()}) {
    auto draw = [&](const render::Options& x) { return dev ? render::render(h, x, *dev) : render::render(h, x); };
    render::Options dry = o;
    dry.view.water = false;
    const render::Image ref = draw(dry);
    EXPECT_EQ(draw(o).pixels, ref.pixels) << "automatic sea level";
    render::Options low = o;
    low.view.has_water_level = true, low.view.water_level = 2971;
    EXPECT_EQ(draw(low).pixels, ref.pixels) << "water at the lowest cell";
    low.view.water_level = 2990;
    EXPECT_NE(draw(low).pixels, ref.pixels) << "water above the lowest cell shows";
  }
}

// Natural material on planes of known slope, lit from straight above the slope's normal plane:
// dividing the centre pixel by Lambert's shade gives the albedo: grey rock on a 60 deg plane,
// green (grass or forest) on a flat one.
TEST(RenderView, NaturalMaterialRockOnSteepGrassOnFlat) {
  for (double slope : {0.0, 60.0}) {
    Heightfield h = plane(65, 65, 10);
    const double g = std::tan(slope * kDeg);
    for (int y = 0; y < h.height; ++y)
      for (int x = 0; x < h.width; ++x) h.at(x, y) = float(g * 10 * (32 - y));  // rising northward
    render::Options o;
    o.mode = render::Mode::Perspective;
    o.view.material = render::Material::Natural;
    o.view.width = o.view.height = 33;
    o.view.haze = 0;
    o.azimuth_deg = 180, o.altitude_deg = 50;  // sun from the south, the slope faces south
    aim(o, 320, 320, 0, 20, 150);
    const double n[3] = {0, std::sin(slope * kDeg), std::cos(slope * kDeg)};
    const double sun[3] = {0, std::cos(50 * kDeg), std::sin(50 * kDeg)};
    const double shade = 0.3 + 0.8 * std::max(0.0, n[1] * sun[1] + n[2] * sun[2]);
    for (Device* dev : {static_cast<Device*>(nullptr), &test::device()}) {
      const render::Image img = dev ? render::render(h, o, *dev) : render::render(h, o);
      const uint8_t* p = px(img, 16, 16);
      const double r = p[0] / shade, gr = p[1] / shade, b = p[2] / shade;
      if (slope > 0) {
        EXPECT_TRUE(r > 70 && r < 170 && std::abs(r - b) < 16 && std::abs(r - gr) < 10)
            << "rock " << r << " " << gr << " " << b;
      } else {
        EXPECT_TRUE(gr > r + 20 && gr > b + 35) << "grass " << r << " " << gr << " " << b;
      }
    }
  }
}

TEST(RenderView, BadCameraIsAClearError) {
  const Heightfield h = plane(8, 8, 10);
  auto message = [&](auto set) {
    render::Options o;
    o.mode = render::Mode::Perspective;
    set(o);
    try {
      (void)render::render(h, o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([](render::Options& o) { o.view.fov_deg = 0; }).find("fov"), std::string::npos);
  EXPECT_NE(message([](render::Options& o) { o.view.fov_deg = 180; }).find("fov"), std::string::npos);
  EXPECT_NE(message([](render::Options& o) { o.view.elevation_deg = 0; }).find("view_elevation"), std::string::npos);
  EXPECT_NE(message([](render::Options& o) { o.view.elevation_deg = 90; }).find("view_elevation"), std::string::npos);
  EXPECT_NE(message([](render::Options& o) { o.view.width = 0; }).find("size"), std::string::npos);
  EXPECT_NE(message([](render::Options& o) {
              o.view.has_water_level = true;
              o.view.water_level = NAN;
            }).find("water_level"),
            std::string::npos);
  EXPECT_NE(message([](render::Options& o) { o.view.water_clarity = 0; }).find("water_clarity"), std::string::npos);
  try {
    (void)render::material_from_name("chalk");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("material"), std::string::npos) << e.what();
  }
}

// The CLI: a perspective PNG of the requested size; bad options name the flag and leave no file.
TEST(RenderView, CliWritesPngAndRefusesBadOptions) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/frontrange_64.asc");
  const auto r = test::run_cli("-q render " + in + " -o " + tmp.path("v.png") +
                               " --mode perspective --size 160x90 --backend host --view-azimuth 120");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  auto img = OIIO::ImageInput::open(tmp.path("v.png"));
  ASSERT_TRUE(img);
  EXPECT_EQ(img->spec().width, 160);
  EXPECT_EQ(img->spec().height, 90);
  EXPECT_EQ(img->spec().nchannels, 3);
  const std::pair<const char*, const char*> bad[] = {
      {"--fov 0", "fov"},
      {"--view-elevation 90", "view-elevation"},
      {"--size 100", "size"},
      {"--view-target 5", "view-target"},
      {"--water-level nan", "water_level"},
      {"--material chalk", "material"},
  };
  for (const auto& [args, name] : bad) {
    const auto e = test::run_cli("-q render " + in + " -o " + tmp.path("x.png") + " --mode perspective --backend host " + args);
    EXPECT_NE(e.exit_code, 0) << args;
    EXPECT_NE(e.out.find(name), std::string::npos) << args << ": " << e.out;
  }
  const auto tif = test::run_cli("-q render " + in + " -o " + tmp.path("x.tif") + " --mode perspective");
  EXPECT_NE(tif.exit_code, 0);
  EXPECT_NE(tif.out.find("georeferencing"), std::string::npos) << tif.out;
  EXPECT_EQ(tmp.count(), 1u) << "only v.png";
}
