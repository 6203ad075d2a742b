// SPDX-License-Identifier: Apache-2.0
// GDAL's conventions on read and write: virtual file systems (/vsizip/, /vsimem/), band
// scale/offset and vertical units (values are metres in memory), and a geotransform carrying the
// cell size in GeoTIFFs of rasters that have no georeferencing (flat: bases).
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>

using namespace terracl;

namespace {

struct Closer {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
using Dataset = std::unique_ptr<GDALDataset, Closer>;

Heightfield ramp(int w, int h, double cell) {
  Heightfield f(w, h);
  f.georef.cell_x = f.georef.cell_y = cell;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) f.at(x, y) = float(100 + 3 * x + 7 * y);
  return f;
}

// A GeoTIFF written by GDAL directly: raw band values, with the given type, scale, offset, unit.
void write_raw_tif(const std::string& path, GDALDataType type, const std::vector<double>& raw, int w, int h,
                   double scale, double offset, const char* unit, std::optional<double> nodata) {
  GDALAllRegister();
  Dataset ds(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(path.c_str(), w, h, 1, type, nullptr));
  ASSERT_TRUE(ds);
  double gt[6] = {300000, 30, 0, 4950000, 0, -30};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.importFromEPSG(32619);
  ds->SetSpatialRef(&srs);
  GDALRasterBand* b = ds->GetRasterBand(1);
  b->SetScale(scale);
  b->SetOffset(offset);
  if (unit) b->SetUnitType(unit);
  if (nodata) b->SetNoDataValue(*nodata);
  std::vector<double> v = raw;
  ASSERT_EQ(b->RasterIO(GF_Write, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0, 0), CE_None);
}

}  // namespace

TEST(GdalConventions, ReadsAndWritesGdalVirtualPaths) {
  test::TempDir dir;
  const Heightfield h = ramp(40, 30, 10.0);
  // /vsimem/: written by GDAL under its final name (there is no folder to rename in) and read back.
  write_heightfield(h, "/vsimem/terracl-test/dem.tif");
  const Heightfield back = read_heightfield("/vsimem/terracl-test/dem.tif");
  EXPECT_EQ(back.z, h.z);
  EXPECT_DOUBLE_EQ(back.georef.cell_x, 10.0);
  VSIUnlink("/vsimem/terracl-test/dem.tif");

  // /vsizip/: a GeoTIFF inside a zip archive, as gdalinfo opens it.
  const std::string tif = dir.path("dem.tif"), zip = dir.path("dem.zip");
  write_heightfield(h, tif);
  std::ifstream in(tif, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  VSILFILE* f = VSIFOpenL(("/vsizip/" + zip + "/inner/dem.tif").c_str(), "wb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(VSIFWriteL(bytes.data(), 1, bytes.size(), f), bytes.size());
  VSIFCloseL(f);
  const Heightfield zipped = read_heightfield("/vsizip/" + zip + "/inner/dem.tif");
  EXPECT_EQ(zipped.z, h.z);
  EXPECT_TRUE(path_exists("/vsizip/" + zip + "/inner/dem.tif"));

  // A missing member is "no such file", named; a format GDAL does not write there is refused.
  try {
    read_heightfield("/vsizip/" + zip + "/inner/missing.tif");
    FAIL() << "a missing member was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.tif: no such file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_heightfield(h, "/vsimem/terracl-test/dem.png"), Error);
}

TEST(GdalConventions, BandScaleOffsetAndNodataFollowGdal) {
  test::TempDir dir;
  const std::string path = dir.path("scaled.tif");
  // Int16 decimetres above a 100 m datum; -9999 is nodata as a raw value.
  write_raw_tif(path, GDT_Int16, {6280, -9999, 16720, 0}, 2, 2, 0.1, 100.0, "m", -9999.0);
  const Heightfield h = read_heightfield(path);
  EXPECT_FLOAT_EQ(h.z[0], 728.0f);
  EXPECT_TRUE(std::isnan(h.z[1]));
  EXPECT_FLOAT_EQ(h.z[2], 1772.0f);
  EXPECT_FLOAT_EQ(h.z[3], 100.0f);
  EXPECT_EQ(h.georef.vertical_units, "m");
}

TEST(GdalConventions, VerticalUnitsInFeetBecomeMetres) {
  test::TempDir dir;
  const std::string ft = dir.path("feet.tif"), us = dir.path("usft.tif"), cm = dir.path("cm.tif");
  write_raw_tif(ft, GDT_Float32, {1000, 2000, 3000, 4000}, 2, 2, 1.0, 0.0, "ft", std::nullopt);
  write_raw_tif(us, GDT_Float32, {1000, 2000, 3000, 4000}, 2, 2, 1.0, 0.0, "US survey foot", std::nullopt);
  write_raw_tif(cm, GDT_Int32, {100000, 200000, 300000, 400000}, 2, 2, 1.0, 0.0, "cm", std::nullopt);
  const Heightfield a = read_heightfield(ft), b = read_heightfield(us), c = read_heightfield(cm);
  for (int i = 0; i < 4; ++i) {
    EXPECT_FLOAT_EQ(a.z[i], float((i + 1) * 1000 * 0.3048)) << i;
    EXPECT_FLOAT_EQ(b.z[i], float((i + 1) * 1000 * 1200.0 / 3937.0)) << i;
    EXPECT_FLOAT_EQ(c.z[i], float((i + 1) * 1000.0)) << i;
  }
  EXPECT_EQ(a.georef.vertical_units, "m");
  EXPECT_EQ(a.metadata.at("terracl:source_vertical_units"), "ft");
  EXPECT_EQ(b.metadata.at("terracl:source_vertical_units"), "US survey foot");
  // Written back in the unit it was read in: the file holds the same feet, and reads as before.
  write_heightfield(a, dir.path("out.tif"));
  Dataset ds(static_cast<GDALDataset*>(GDALOpen(dir.path("out.tif").c_str(), GA_ReadOnly)));
  EXPECT_STREQ(ds->GetRasterBand(1)->GetUnitType(), "ft");
  float raw[4];
  ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 2, 2, raw, 2, 2, GDT_Float32, 0, 0), CE_None);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(raw[i], float((i + 1) * 1000)) << i;
  EXPECT_EQ(read_heightfield(dir.path("out.tif")).z, a.z);
}

// Lengths in metres from a DEM in feet go back out in feet, on every write path (untiled, tiled,
// streamed values), and keep an integer input's type; angles and areas are not lengths.
TEST(GdalConventions, FeetInFeetOutOnEveryWritePath) {
  test::TempDir dir;
  const int w = 80, h = 70;
  std::vector<double> raw(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)  // a valley with a pit: fill changes cells, TRI is not constant
      raw[size_t(y) * w + x] = std::round(3000 + 4.0 * std::abs(x - 40) + 2.5 * y + 40 * std::sin(0.3 * x) * std::cos(0.2 * y));
  raw[size_t(35) * w + 40] -= 200;
  const std::string ft = dir.path("ft.tif");
  write_raw_tif(ft, GDT_Int16, raw, w, h, 1.0, 0.0, "ft", std::nullopt);
  auto cli = [&](const std::string& args) {
    const auto r = test::run_cli(args);
    ASSERT_EQ(r.exit_code, 0) << args << "\n" << r.out;
  };
  auto open = [](const std::string& p) { return Dataset(static_cast<GDALDataset*>(GDALOpen(p.c_str(), GA_ReadOnly))); };
  auto band = [&](const std::string& p) {
    Dataset ds = open(p);
    std::vector<double> v(size_t(w) * h);
    EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0, 0), CE_None);
    return v;
  };
  auto unit = [&](const std::string& p) { return std::string(open(p)->GetRasterBand(1)->GetUnitType()); };

  // convert: the same Int16 feet, as gdal_translate keeps them.
  cli("convert " + ft + " " + dir.path("c.tif"));
  EXPECT_EQ(open(dir.path("c.tif"))->GetRasterBand(1)->GetRasterDataType(), GDT_Int16);
  EXPECT_EQ(unit(dir.path("c.tif")), "ft");
  EXPECT_EQ(band(dir.path("c.tif")), raw);

  // fill, untiled and tiled: feet, equal, and the pit raised to its spill height in feet.
  cli("fill_depressions " + ft + " -o " + dir.path("f1.tif"));
  cli("fill_depressions " + ft + " -o " + dir.path("f2.tif") + " --tile 32");
  EXPECT_EQ(unit(dir.path("f1.tif")), "ft");
  EXPECT_EQ(unit(dir.path("f2.tif")), "ft");
  const std::vector<double> f1 = band(dir.path("f1.tif"));
  EXPECT_EQ(f1, band(dir.path("f2.tif")));
  EXPECT_GT(f1[size_t(35) * w + 40], raw[size_t(35) * w + 40] + 100);
  EXPECT_EQ(f1[size_t(10) * w + 5], raw[size_t(10) * w + 5]);

  // TRI (a length): feet, the metres TRI / 0.3048, untiled and tiled alike. Slope (an angle) and
  // drainage area (m2) are written as they are.
  cli("render " + ft + " --mode tri -o " + dir.path("tri.tif"));
  cli("render " + ft + " --mode tri -o " + dir.path("tri2.tif") + " --tile 32");
  EXPECT_EQ(unit(dir.path("tri.tif")), "ft");
  EXPECT_EQ(band(dir.path("tri.tif")), band(dir.path("tri2.tif")));
  render::Options o;
  o.mode = render::Mode::TRI;
  o.compute_edges = false;  // the CLI's default: the border is nodata (-9999, not divided)
  const Heightfield metres = read_heightfield(ft);
  const Heightfield tri_m = render::values(metres, o);
  const std::vector<double> tri_ft = band(dir.path("tri.tif"));
  for (size_t i = 0; i < tri_ft.size(); ++i) {
    EXPECT_EQ(std::isfinite(tri_m.z[i]), tri_ft[i] != -9999.0) << i;
    if (std::isfinite(tri_m.z[i])) EXPECT_NEAR(tri_ft[i], tri_m.z[i] / 0.3048, 1e-5 * (1 + tri_ft[i])) << i;
  }
  cli("render " + ft + " --mode slope -o " + dir.path("slope.tif"));
  EXPECT_EQ(unit(dir.path("slope.tif")), "degrees");
  cli("drainage " + ft + " -o " + dir.path("area.tif"));
  EXPECT_EQ(unit(dir.path("area.tif")), "m2");
}

TEST(GdalConventions, GeoTiffOfAnUngeoreferencedRasterCarriesItsCellSize) {
  test::TempDir dir;
  const Heightfield h = ramp(50, 20, 12.5);  // as a flat: base: cell size, no geotransform, no CRS
  ASSERT_FALSE(h.georef.has_geotransform);
  write_heightfield(h, dir.path("flat.tif"));
  // GDAL (and so QGIS, GRASS) reads 12.5 m cells, north up, over [0, 625] x [0, 250] m.
  Dataset ds(static_cast<GDALDataset*>(GDALOpen(dir.path("flat.tif").c_str(), GA_ReadOnly)));
  double gt[6];
  ASSERT_EQ(ds->GetGeoTransform(gt), CE_None);
  EXPECT_EQ(gt[0], 0.0);
  EXPECT_EQ(gt[1], 12.5);
  EXPECT_EQ(gt[3], 250.0);
  EXPECT_EQ(gt[5], -12.5);
  // terracl reads it back as it was: not georeferenced, same cells.
  const Heightfield back = read_heightfield(dir.path("flat.tif"));
  EXPECT_FALSE(back.georef.has_geotransform);
  EXPECT_EQ(back.georef.cell_x, 12.5);
  EXPECT_EQ(back.z, h.z);
}

TEST(GdalConventions, CliWritesAnyGdalFormatWithGdalSpellings) {
  test::TempDir dir;
  const std::string hgt = test::data_path("dem/N44W072.hgt");
  // .asc is GDAL's AAIGrid: its .prj companion is renamed into place beside it, nothing else left.
  auto r = test::run_cli("convert '" + hgt + "' '" + dir.path("dem.asc") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(std::filesystem::exists(dir.path("dem.prj")));
  for (const auto& e : std::filesystem::directory_iterator(dir.dir()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  const Heightfield a = read_heightfield(dir.path("dem.asc")), src = read_heightfield(hgt);
  EXPECT_EQ(a.z, src.z);
  EXPECT_TRUE(a.georef.geographic);
  // -of names the driver (an extension several drivers claim); -ot and -co as gdal_translate's.
  r = test::run_cli("convert '" + hgt + "' '" + dir.path("dem.grd") + "' -of GS7BG -ot Float32");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  Dataset ds(static_cast<GDALDataset*>(GDALOpen(dir.path("dem.grd").c_str(), GA_ReadOnly)));
  ASSERT_TRUE(ds);
  EXPECT_STREQ(ds->GetDriver()->GetDescription(), "GS7BG");  // a Float64 format whatever -ot says
  r = test::run_cli("convert '" + hgt + "' '" + dir.path("dem.img") + "' -ot Float32");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  Dataset img(static_cast<GDALDataset*>(GDALOpen(dir.path("dem.img").c_str(), GA_ReadOnly)));
  EXPECT_STREQ(img->GetDriver()->GetDescription(), "HFA");
  EXPECT_EQ(img->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
  r = test::run_cli("convert '" + hgt + "' '" + dir.path("dem2.grd") + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("choose one with --of"), std::string::npos) << r.out;
  // warp with gdalwarp's spellings; the input's Int16 is kept unless -ot says otherwise.
  r = test::run_cli("warp '" + hgt + "' -o '" + dir.path("utm.tif") + "' -t_srs EPSG:32619 -tr 200 200 -co COMPRESS=LZW");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  Dataset w(static_cast<GDALDataset*>(GDALOpen(dir.path("utm.tif").c_str(), GA_ReadOnly)));
  EXPECT_EQ(w->GetRasterBand(1)->GetRasterDataType(), GDT_Int16);
  EXPECT_STREQ(w->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE"), "LZW");
  // info and a stage read a DEM inside a zip archive.
  const std::string zip = dir.path("dem.zip");
  {
    std::ifstream in(dir.path("utm.tif"), std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    VSILFILE* f = VSIFOpenL(("/vsizip/" + zip + "/utm.tif").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    VSIFWriteL(bytes.data(), 1, bytes.size(), f);
    VSIFCloseL(f);
  }
  r = test::run_cli("info /vsizip/" + zip + "/utm.tif");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("WGS 84 / UTM zone 19N"), std::string::npos) << r.out;
  r = test::run_cli("fill_depressions /vsizip/" + zip + "/utm.tif -o '" + dir.path("filled.tif") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.out;
}

// A 16-bit PNG carries <file>.png.aux.xml, a RAW16 heightmap <file>.r16.hdr (ENVI): GDAL opens
// both georeferenced, with the codes as metres through the band's scale and offset.
TEST(GdalConventions, Png16AndRaw16HaveGdalMetadataInMetres) {
  for (const char* name : {"h.png", "h.r16"}) {
    SCOPED_TRACE(name);
    test::TempDir dir;
    Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
    h.z[5] = NAN;
    write_heightfield(h, dir.path(name));
    const bool png = std::string(name) == "h.png";
    ASSERT_TRUE(std::filesystem::exists(dir.path(name) + (png ? ".aux.xml" : ".hdr")));
    // GDAL (QGIS, rasterio) reads the image's georeferencing and its codes as metres.
    Dataset ds(static_cast<GDALDataset*>(GDALOpen(dir.path(name).c_str(), GA_ReadOnly)));
    ASSERT_TRUE(ds);
    EXPECT_EQ(ds->GetRasterXSize(), h.width);
    EXPECT_EQ(ds->GetRasterYSize(), h.height);
    double gt[6];
    ASSERT_EQ(ds->GetGeoTransform(gt), CE_None);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(gt[i], h.georef.geotransform[i], 1e-12 * std::fabs(gt[i]) + 1e-15) << i;
    ASSERT_TRUE(ds->GetSpatialRef());
    EXPECT_TRUE(ds->GetSpatialRef()->IsGeographic());
    GDALRasterBand* b = ds->GetRasterBand(1);
    EXPECT_EQ(b->GetRasterDataType(), GDT_UInt16);
    int has_nd = 0;
    EXPECT_EQ(b->GetNoDataValue(&has_nd), 0.0);
    EXPECT_TRUE(has_nd);
    std::vector<double> codes(h.size());
    ASSERT_EQ(b->RasterIO(GF_Read, 0, 0, h.width, h.height, codes.data(), h.width, h.height, GDT_Float64, 0, 0), CE_None);
    const double step = b->GetScale();
    EXPECT_GT(step, 0.0);
    for (size_t i = 0; i < h.size(); ++i) {
      if (std::isnan(h.z[i])) {
        EXPECT_EQ(codes[i], 0.0);
        continue;
      }
      ASSERT_NEAR(codes[i] * step + b->GetOffset(), h.z[i], 0.51 * step) << i;
    }
    // terracl's own reader (with the JSON sidecar) is unchanged by GDAL's file beside it.
    const Heightfield back = read_heightfield(dir.path(name));
    EXPECT_TRUE(std::isnan(back.z[5]));
    EXPECT_EQ(back.width, h.width);
  }
}
