// SPDX-License-Identifier: Apache-2.0
// warp and resize: the same values as the gdalwarp program with the same options,
// nodata kept, engine presets' sizes and Z scale, and amplify's error naming the warp command.
#include "test_helpers.hpp"

#include <filesystem>

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/warp.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fmt/format.h>
#include <cstdlib>
#include <fstream>

using namespace terracl;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

// The georeferenced SRTM crop (EPSG:4326, Int16, nodata -32768) as float32 with a void, so the
// warper's nodata handling is exercised.
std::string crop_with_void(const test::TempDir& dir) {
  Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  for (int y = 40; y < 50; ++y)
    for (int x = 60; x < 75; ++x) h.at(x, y) = NAN;
  const std::string path = dir.path("in.tif");
  write_heightfield(h, path);
  return path;
}

// Same size, geotransform, nodata cells, and values to 1e-4 relative.
void expect_same_raster(const std::string& ours, const std::string& ref, const std::string& what) {
  const Heightfield a = read_heightfield(ours), b = read_heightfield(ref);
  ASSERT_EQ(a.width, b.width) << what;
  ASSERT_EQ(a.height, b.height) << what;
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(a.georef.geotransform[i], b.georef.geotransform[i], 1e-9) << what << " gt " << i;
  size_t nodata = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(std::isnan(a.z[i]), std::isnan(b.z[i])) << what << " cell " << i;
    if (std::isnan(a.z[i])) {
      ++nodata;
      continue;
    }
    ASSERT_NEAR(a.z[i], b.z[i], 1e-4 * std::fabs(b.z[i]) + 1e-6) << what << " cell " << i;
  }
  EXPECT_GT(nodata, 0u) << what << ": the void and the reprojection margins must stay nodata";
}

void gdalwarp(const std::string& args) {
  const std::string cmd = "gdalwarp -q -overwrite " + args + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

}  // namespace

TEST(Warp, ReprojectsLikeGdalwarpForEveryResampling) {
  test::TempDir dir;
  const std::string in = crop_with_void(dir);
  for (const std::string r : {"near", "bilinear", "cubic", "cubicspline", "lanczos", "average"}) {
    const std::string ours = dir.path("ours_" + r + ".tif"), ref = dir.path("ref_" + r + ".tif");
    const auto c = test::run_cli("warp " + q(in) + " -o " + q(ours) + " --t-srs EPSG:32619 --tr 100 100 --resampling " + r);
    ASSERT_EQ(c.exit_code, 0) << c.out;
    gdalwarp("-t_srs EPSG:32619 -tr 100 100 -r " + r + " -ot Float32 " + q(in) + " " + q(ref));
    expect_same_raster(ours, ref, r);
  }
  const Heightfield out = read_heightfield(dir.path("ours_bilinear.tif"));
  EXPECT_FALSE(out.georef.geographic);
  EXPECT_NEAR(out.georef.cell_x, 100.0, 1e-9);
  ASSERT_TRUE(out.georef.nodata.has_value());
  EXPECT_EQ(*out.georef.nodata, -32768.0);
}

TEST(Warp, ProjwinAndSizeLikeGdalwarp) {
  test::TempDir dir;
  const std::string in = crop_with_void(dir);
  // A window in degrees (gdalwarp -te xmin ymin xmax ymax = projwin ulx lry lrx uly).
  auto c = test::run_cli("warp " + q(in) + " -o " + q(dir.path("w.tif")) +
                         " --projwin -71.48 44.74 -71.43 44.70 --resampling cubic");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  gdalwarp("-te -71.48 44.70 -71.43 44.74 -r cubic -ot Float32 " + q(in) + " " + q(dir.path("w_ref.tif")));
  expect_same_raster(dir.path("w.tif"), dir.path("w_ref.tif"), "projwin");
  c = test::run_cli("warp " + q(in) + " -o " + q(dir.path("s.tif")) + " --ts 300 200 --resampling bilinear");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  gdalwarp("-ts 300 200 -r bilinear -ot Float32 " + q(in) + " " + q(dir.path("s_ref.tif")));
  expect_same_raster(dir.path("s.tif"), dir.path("s_ref.tif"), "ts");
}

TEST(Warp, BadOptionsAreClearErrors) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--tr 30 30 --ts 10 10", "exclude each other"},
      {"--t-srs EPSG:999999", "not a CRS"},
      {"--tr -1 30", "positive"},
      {"--projwin 0 0 1 1", "lrx > ulx and uly > lry"},
      {"--projwin 10 10 11 9", "does not overlap"},
      {"--resampling mode", "mode"},
  };
  for (const auto& [args, expected] : bad) {
    const auto r = test::run_cli("warp " + q(in) + " -o " + q(dir.path("x.tif")) + " " + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.out.find(expected), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_EQ(dir.count(), 0u) << "a refused warp wrote something";
}

TEST(Warp, LocalGridWithoutGeoreferencing) {
  Heightfield h = test::smooth_terrain(64, 48, 10.0);
  const Heightfield r = warp(h, WarpOptions{"", std::array<double, 2>{20.0, 20.0}, std::nullopt, "average", std::nullopt});
  EXPECT_EQ(r.width, 32);
  EXPECT_EQ(r.height, 24);
  EXPECT_FALSE(r.georef.has_geotransform);
  EXPECT_DOUBLE_EQ(r.georef.cell_x, 20.0);
  // average of 2 x 2 blocks: the block mean
  const double mean = (h.at(0, 0) + h.at(1, 0) + h.at(0, 1) + h.at(1, 1)) / 4.0;
  EXPECT_NEAR(r.at(0, 0), mean, 1e-3);
  EXPECT_THROW(warp(h, WarpOptions{"EPSG:32619"}), Error);  // no CRS to reproject from
}

// --size takes gdalwarp's "W H" and render's "WxH"; anything else is a usage error naming the word.
TEST(Resize, SizeAsTwoWordsOrWidthByHeight) {
  test::TempDir dir;
  const std::string in = crop_with_void(dir);
  for (const std::string size : {"40 30", "40x30"}) {
    const auto c = test::run_cli("-q resize " + q(in) + " -o " + q(dir.path("s.tif")) + " --size " + size);
    ASSERT_EQ(c.exit_code, 0) << size << ": " << c.out;
    const Heightfield r = read_heightfield(dir.path("s.tif"));
    EXPECT_EQ(r.width, 40) << size;
    EXPECT_EQ(r.height, 30) << size;
  }
  for (const std::string size : {"40", "0x30", "40xq"}) {
    const auto c = test::run_cli("-q resize " + q(in) + " -o " + q(dir.path("bad.tif")) + " --size " + size);
    EXPECT_EQ(c.exit_code, 2) << size << ": " << c.out;
    EXPECT_NE(c.out.find("--size"), std::string::npos) << c.out;
    EXPECT_FALSE(std::filesystem::exists(dir.path("bad.tif")));
  }
}

TEST(Resize, EnginePresetsKeepTheExtentAndRecordTheZScale) {
  test::TempDir dir;
  const std::string in = crop_with_void(dir);
  const Heightfield src = read_heightfield(in);
  const auto c = test::run_cli("resize " + q(in) + " -o " + q(dir.path("u.r16")) + " --preset unreal-505");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("Scale Z"), std::string::npos) << c.out;
  const Heightfield r = read_heightfield(dir.path("u.r16"));
  EXPECT_EQ(r.width, 505);
  EXPECT_EQ(r.height, 505);
  const auto& g = r.georef.geotransform;
  const auto& s = src.georef.geotransform;
  EXPECT_NEAR(g[0], s[0], 1e-12);
  EXPECT_NEAR(g[3], s[3], 1e-12);
  EXPECT_NEAR(g[1] * 505, s[1] * src.width, 1e-9);
  EXPECT_NEAR(g[5] * 505, s[5] * src.height, 1e-9);
  EXPECT_GT(r.count_nodata(), 0u) << "the void must stay nodata through resize and RAW16";
  std::ifstream sc(dir.path("u.r16.json"));
  const nlohmann::json j = nlohmann::json::parse(sc);
  const double range = j["zmax"].get<double>() - j["zmin"].get<double>();
  // Code 0 is nodata, so data span 65534 codes; Unreal's Scale Z 100 spans 65535/128 = 512 m.
  EXPECT_NEAR(j["engine"]["unreal_z_scale"].get<double>(), range * 12800.0 / 65534.0, 1e-9);
  // Geographic cells are not square: Unreal's Scale X and Y each take their own cell size (cm).
  EXPECT_NEAR(j["engine"]["unreal_x_scale"].get<double>(), r.georef.cell_x * 100.0, 1e-9);
  EXPECT_NEAR(j["engine"]["unreal_y_scale"].get<double>(), r.georef.cell_y * 100.0, 1e-9);
  EXPECT_GT(std::fabs(r.georef.cell_x - r.georef.cell_y), 0.05 * r.georef.cell_x)
      << "the crop's cells must be non-square for this check to mean anything";
  EXPECT_NE(c.out.find(fmt::format("Scale X {:.4f}  Scale Y {:.4f}", r.georef.cell_x * 100.0, r.georef.cell_y * 100.0)),
            std::string::npos)
      << c.out;
  EXPECT_TRUE(j["engine"].contains("warning")) << "geographic cells are not square";
  for (const auto& [name, size] : engine_presets()) EXPECT_EQ(engine_preset_size(name), size);
  EXPECT_EQ(engine_preset_size("unity-1025"), 1025);
  EXPECT_EQ(engine_preset_size("unreal-8129"), 8129);
  EXPECT_THROW(engine_preset_size("unreal-1024"), Error);
}

TEST(Resize, EngineScaleMatchesUnrealsConvention) {
  // 512 m over the full 16-bit range is Unreal's Scale Z 100 (to one code in 65535).
  const EngineScale s = engine_scale(-256.0, 256.0, false, 2.0);
  EXPECT_NEAR(s.unreal_z_scale, 100.0, 0.002);
  EXPECT_DOUBLE_EQ(s.unreal_x_scale, 200.0);
  EXPECT_DOUBLE_EQ(s.unreal_y_scale, 200.0);
  const EngineScale geo = engine_scale(0.0, 100.0, false, 66.275, 92.602);  // SRTM3 at 44 N
  EXPECT_DOUBLE_EQ(geo.unreal_x_scale, 6627.5);
  EXPECT_DOUBLE_EQ(geo.unreal_y_scale, 9260.2);
  EXPECT_NEAR(s.unreal_z_location, 0.0, 1.0);  // code 32768 sits at the middle of the range
  EXPECT_NEAR(s.unity_height, 512.0, 1e-9);
  EXPECT_NEAR(s.unity_position_y, -256.0, 1e-9);
  // Unity: elevation = Position Y + code / 65535 * Height, also with code 0 reserved.
  const EngineScale n = engine_scale(100.0, 1100.0, true, 30.0);
  EXPECT_NEAR(n.unity_position_y + 1.0 / 65535.0 * n.unity_height, 100.0, 1e-9);
  EXPECT_NEAR(n.unity_position_y + n.unity_height, 1100.0, 1e-9);
}

TEST(Resize, AmplifyCellMismatchNamesTheWarpCommand) {
  Heightfield low = test::smooth_terrain(40, 40, 30.0);
  Heightfield ex = test::smooth_terrain(64, 64, 66.0);
  try {
    amplify_from_exemplars(low, {ex}, LearnOptions{}, AmplifyOptions{}, {});
    FAIL() << "a 66 m exemplar cannot amplify 30 m cells to 7.5 m";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("terracl warp <input> -o input_264m.tif --tr 264 264 --resampling average"),
              std::string::npos)
        << e.what();
  }
}

TEST(Warp, PipelineStagesAndCogWriter) {
  test::TempDir dir;
  nlohmann::json p = {{"pipeline",
                       {test::data_path("crops/presidential_128x96.tif"),
                        {{"type", "warp"}, {"t_srs", "EPSG:32619"}, {"tr", {90, 90}}, {"resampling", "cubic"}},
                        {{"type", "resize"}, {"preset", "unity-513"}},
                        {{"type", "write"}, {"filename", dir.path("out.tif")}, {"cog", true},
                         {"creation_options", {"COMPRESS=LZW"}}}}}};
  std::ofstream(dir.path("p.json")) << p.dump();
  auto r = test::run_cli("run " + q(dir.path("p.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield h = read_heightfield(dir.path("out.tif"));
  EXPECT_EQ(h.width, 513);
  EXPECT_FALSE(h.georef.geographic);
  r = {0, ""};
  FILE* g = popen(("gdalinfo " + q(dir.path("out.tif"))).c_str(), "r");
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, g)) > 0;) r.out.append(buf, n);
  pclose(g);
  EXPECT_NE(r.out.find("engine_unreal_z_scale="), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("LAYOUT=COG"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("COMPRESSION=LZW"), std::string::npos) << r.out;
  // Bad stage options are refused by --validate with the JSON path.
  p["pipeline"][1]["tr"] = {90};
  p["pipeline"][3]["filename"] = dir.path("out.png");
  std::ofstream(dir.path("bad.json")) << p.dump();
  r = test::run_cli("run --validate " + q(dir.path("bad.json")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("/pipeline/3"), std::string::npos) << r.out;
}

// A new user's run (lead): a metric DEM with a non-square extent resized to a square preset got the
// advice "warp to a metric CRS first", and the warped .asc kept "crs_assumed: WGS 84" in its metadata.
TEST(Resize, NonSquareCellsGetAdviceThatFitsTheirCause) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/frontrange_64.asc");
  auto c = test::run_cli("warp " + q(in) + " -o " + q(dir.path("utm.tif")) + " --t-srs EPSG:32613 --tr 90 90");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  const Heightfield utm = read_heightfield(dir.path("utm.tif"));
  EXPECT_EQ(utm.metadata.count("terracl:crs_assumed"), 0u) << "the reprojected output's CRS is not assumed";
  ASSERT_NE(utm.width, utm.height);
  c = test::run_cli("resize " + q(dir.path("utm.tif")) + " -o " + q(dir.path("e.r16")) + " --preset unreal-505");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("extent's proportions"), std::string::npos) << c.out;
  EXPECT_EQ(c.out.find("metric CRS"), std::string::npos) << c.out;
  const auto sc = nlohmann::json::parse(std::ifstream(dir.path("e.r16.json")));
  EXPECT_NE(sc["engine"]["warning"].get<std::string>().find("extent's proportions"), std::string::npos) << sc.dump();
  // A geographic raster keeps the warp advice.
  c = test::run_cli("resize " + q(in) + " -o " + q(dir.path("g.r16")) + " --preset unreal-505");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("geographic CRS"), std::string::npos) << c.out;
}

// Wider than one block of GDAL's warped VRT (512 cells): the cells equal the gdalwarp program's bit
// for bit (a VRT warps each block with its own row approximation and differed on 96 % of cells).
TEST(Warp, WideReprojectionEqualsGdalwarpBitForBit) {
  test::TempDir dir;
  const std::string in = test::data_path("dem/N44W072.hgt"), ours = dir.path("ours.tif"), ref = dir.path("ref.tif");
  const auto c = test::run_cli("warp " + q(in) + " -o " + q(ours) + " -t_srs EPSG:32619 -tr 60 60 -r cubic -ot Float32");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  gdalwarp("-t_srs EPSG:32619 -tr 60 60 -r cubic -ot Float32 " + q(in) + " " + q(ref));
  const Heightfield a = read_heightfield(ours), b = read_heightfield(ref);
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  ASSERT_GT(a.width, 1000);
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); ++i)
    differ += !(a.z[i] == b.z[i] || (std::isnan(a.z[i]) && std::isnan(b.z[i])));
  EXPECT_EQ(differ, 0u);
}
