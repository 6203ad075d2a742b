// SPDX-License-Identifier: Apache-2.0
// Nodata round trips in every format terracl writes: code 0 reserved in PNG16/RAW16
// and recorded in the sidecar, NaN in EXR, the GeoTIFF nodata tag (also for integer types);
// GeoTIFF creation options and COG; the warning for 16-bit inputs without a sidecar.
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <gdal_priv.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace terracl;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

Heightfield crop_with_holes() {
  Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  h.z[0] = NAN;
  h.z[1000] = NAN;
  h.z[h.size() - 1] = NAN;
  return h;
}

nlohmann::json sidecar(const std::string& path) {
  std::ifstream in(path + ".json");
  return nlohmann::json::parse(in);
}

// Same nodata cells; the others within `tol` metres.
void expect_round_trip(const Heightfield& h, const Heightfield& r, double tol, const std::string& what) {
  ASSERT_EQ(r.width, h.width) << what;
  ASSERT_EQ(r.height, h.height) << what;
  for (size_t i = 0; i < h.size(); ++i) {
    ASSERT_EQ(std::isnan(h.z[i]), std::isnan(r.z[i])) << what << " cell " << i;
    if (!std::isnan(h.z[i])) ASSERT_NEAR(r.z[i], h.z[i], tol) << what << " cell " << i;
  }
}

double step(const Heightfield& h, bool reserved) {
  double lo = 1e30, hi = -1e30;
  for (float v : h.z)
    if (std::isfinite(v)) lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
  return (hi - lo) / (reserved ? 65534.0 : 65535.0);
}

}  // namespace

TEST(IONodata, Png16ReservesCodeZeroAndRestoresNodata) {
  test::TempDir dir;
  const Heightfield h = crop_with_holes();
  write_heightfield(h, dir.path("a.png"));
  const auto sc = sidecar(dir.path("a.png"));
  EXPECT_EQ(sc["nodata_code"], 0);
  EXPECT_EQ(sc["nodata"], -32768.0);
  const Heightfield r = read_heightfield(dir.path("a.png"));
  expect_round_trip(h, r, 0.51 * step(h, true), "png16");
  ASSERT_TRUE(r.georef.nodata.has_value());
  EXPECT_EQ(*r.georef.nodata, -32768.0);
  // The lowest elevation takes code 1, not the nodata code.
  const HeightStats s = compute_stats(r), s0 = compute_stats(h);
  EXPECT_NEAR(s.min, s0.min, 1e-3);
  EXPECT_EQ(s.nodata, 3u);
}

TEST(IONodata, Raw16ReservesCodeZeroAndRestoresNodata) {
  test::TempDir dir;
  const Heightfield h = crop_with_holes();
  write_heightfield(h, dir.path("a.r16"));
  EXPECT_EQ(sidecar(dir.path("a.r16"))["nodata_code"], 0);
  std::ifstream raw(dir.path("a.r16"), std::ios::binary);
  unsigned char first[2];
  raw.read(reinterpret_cast<char*>(first), 2);
  EXPECT_EQ(first[0] | first[1] << 8, 0) << "cell 0 is nodata: code 0";
  expect_round_trip(h, read_heightfield(dir.path("a.r16")), 0.51 * step(h, true), "raw16");
  // Without nodata, the full 0..65535 range is data (files written before keep their meaning).
  Heightfield full = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  write_heightfield(full, dir.path("b.r16"));
  EXPECT_FALSE(sidecar(dir.path("b.r16")).contains("nodata_code"));
  expect_round_trip(full, read_heightfield(dir.path("b.r16")), 0.51 * step(full, false), "raw16 without nodata");
}

TEST(IONodata, ExrAndGeoTiffCarryNodata) {
  test::TempDir dir;
  const Heightfield h = crop_with_holes();
  write_heightfield(h, dir.path("a.exr"));
  expect_round_trip(h, read_heightfield(dir.path("a.exr")), 0.0, "exr");
  for (const std::string type : {"Float32", "Float64", "Int16", "Int32", "UInt16"}) {
    WriteOptions wo;
    wo.output_type = type;
    const std::string out = dir.path("t_" + type + ".tif");
    write_heightfield(h, out, wo);
    GDALAllRegister();
    GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(out.c_str(), GA_ReadOnly));
    ASSERT_TRUE(ds) << type;
    EXPECT_STREQ(GDALGetDataTypeName(ds->GetRasterBand(1)->GetRasterDataType()), type.c_str());
    int has = 0;
    ds->GetRasterBand(1)->GetNoDataValue(&has);
    EXPECT_TRUE(has) << type << ": the nodata tag is set";
    GDALClose(ds);
    // Integer types round the (integer SRTM) elevations exactly.
    expect_round_trip(h, read_heightfield(out), 0.0, type);
  }
}

TEST(IONodata, CreationOptionsAndCog) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  auto c = test::run_cli("convert " + q(in) + " " + q(dir.path("cog.tif")) + " --cog --co COMPRESS=LZW");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  GDALAllRegister();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(dir.path("cog.tif").c_str(), GA_ReadOnly));
  ASSERT_TRUE(ds);
  const char* layout = ds->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE");
  const char* comp = ds->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  EXPECT_STREQ(layout ? layout : "", "COG");
  EXPECT_STREQ(comp ? comp : "", "LZW");
  GDALClose(ds);
  expect_round_trip(read_heightfield(in), read_heightfield(dir.path("cog.tif")), 0.0, "cog");
  // Misspelt keys, options on a format without them, and types terracl does not write are refused.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {q(dir.path("x.tif")) + " --co COMPRES=LZW", "COMPRES is not one the GTiff driver knows"},
      {q(dir.path("x.tif")) + " --co COMPRESS", "KEY=VALUE"},
      {q(dir.path("x.png")) + " --co COMPRESS=LZW", "apply to GDAL outputs"},
      {q(dir.path("x.tif")) + " --ot Byte", "Byte"},
  };
  for (const auto& [args, expected] : bad) {
    c = test::run_cli("convert " + q(in) + " " + args);
    EXPECT_NE(c.exit_code, 0) << args;
    EXPECT_NE(c.out.find(expected), std::string::npos) << args << "\n" << c.out;
  }
  EXPECT_EQ(dir.count(), 1u) << "a refused convert left a file";
}

TEST(IONodata, SidecarlessSixteenBitWarnsAndTakesScaleOptions) {
  test::TempDir dir;
  Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  write_heightfield(h, dir.path("gaea.png"));
  std::filesystem::remove(dir.path("gaea.png.json"));  // as Gaea / World Machine write them
  std::vector<std::string> warnings;
  set_warning_handler([&](const std::string& m) { warnings.push_back(m); });
  read_heightfield(dir.path("gaea.png"));
  ReadOptions ro;
  ro.zmin = 100;
  ro.zmax = 1000;
  ro.cell_size = 30;
  const Heightfield scaled = read_heightfield(dir.path("gaea.png"), ro);
  set_warning_handler({});
  ASSERT_EQ(warnings.size(), 1u) << "one warning, for the read without options";
  EXPECT_NE(warnings[0].find("--zmin/--zmax/--cell-size"), std::string::npos) << warnings[0];
  EXPECT_DOUBLE_EQ(scaled.georef.cell_x, 30.0);
  // Every reading subcommand takes the scale and warns without it.
  for (const std::string cmd : {"info", "metrics", "render", "erode", "amplify", "fill_nodata"}) {
    const auto r = test::run_cli(cmd + " " + q(dir.path("gaea.png")) + " --help");
    EXPECT_NE(r.out.find("--cell-size"), std::string::npos) << cmd << "\n" << r.out;
    EXPECT_NE(r.out.find("--zmin"), std::string::npos) << cmd;
  }
  auto r = test::run_cli("info --json " + q(dir.path("gaea.png")));
  EXPECT_NE(r.out.find("warning"), std::string::npos) << r.out;
  r = test::run_cli("info --json " + q(dir.path("gaea.png")) + " --zmin 100 --zmax 1000 --cell-size 30");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_DOUBLE_EQ(j["cell_x_m"].get<double>(), 30.0);
  EXPECT_NEAR(j["min"].get<double>(), 100.0, 1e-3);
  EXPECT_NEAR(j["max"].get<double>(), 1000.0, 1e-3);
}
