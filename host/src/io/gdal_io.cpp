// SPDX-License-Identifier: Apache-2.0
// GDAL backend: every georeferenced raster on read (GeoTIFF, SRTM .hgt, ESRI ASCII grid, ...),
// float32 GeoTIFF on write. GDAL's own error messages are captured and passed on, so the user
// sees why a file was refused.
#include "io/gdal_common.hpp"
#include "io/gdal_window.hpp"
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace terracl::io {
namespace {

void CPL_STDCALL quiet_handler(CPLErr, CPLErrorNum, const char*) {}

bool looks_like_degrees(const std::array<double, 6>& gt, int w, int h) {
  const double x0 = gt[0], y0 = gt[3], x1 = gt[0] + gt[1] * w + gt[2] * h, y1 = gt[3] + gt[4] * w + gt[5] * h;
  const double cell = std::max(std::fabs(gt[1]), std::fabs(gt[5]));
  return cell > 0 && cell < 0.1 && std::fabs(x0) <= 180 && std::fabs(x1) <= 180 && std::fabs(y0) <= 90 &&
         std::fabs(y1) <= 90;
}

// The geotransform write_local_geotransform gives a raster without georeferencing: read back, it
// is no georeferencing again (the cell size comes from terracl_cell_x/y as before), so a round
// trip through a GeoTIFF leaves the heightfield as it was.
bool is_local_geotransform(GDALDataset& ds, const double* gt) {
  const char* cx = ds.GetMetadataItem("terracl_cell_x");
  const char* cy = ds.GetMetadataItem("terracl_cell_y");
  if (!cx || !cy || ds.GetSpatialRef()) return false;
  const double x = std::strtod(cx, nullptr), y = std::strtod(cy, nullptr);
  return gt[0] == 0.0 && gt[1] == x && gt[2] == 0.0 && gt[3] == y * ds.GetRasterYSize() && gt[4] == 0.0 && gt[5] == -y;
}

// The band type --ot names, among those terracl writes.
GDALDataType output_band_type(const WriteOptions& wo) {
  const GDALDataType type = GDALGetDataTypeByName(wo.output_type.c_str());
  if (type != GDT_Float32 && type != GDT_Float64 && type != GDT_Int16 && type != GDT_UInt16 && type != GDT_Int32)
    fail("io", "output type '{}' is not one terracl writes; use Float32, Float64, Int16, UInt16 or Int32",
         abbreviate(wo.output_type, 30));
  return type;
}

// The user's --co KEY=VALUE added to (and overriding) `opts`. A key the driver does not list is
// refused instead of writing a file without it (GDAL only warns); `opts` is freed on a refusal.
char** add_creation_options(char** opts, GDALDriver& drv, const std::string& driver, const WriteOptions& wo) {
  const char* list = drv.GetMetadataItem(GDAL_DMD_CREATIONOPTIONLIST);
  for (const std::string& kv : wo.creation_options) {
    const auto eq = kv.find('=');
    const std::string key = eq == std::string::npos ? std::string() : kv.substr(0, eq);
    if (key.empty()) {
      CSLDestroy(opts);
      fail("io", "creation option '{}' must be KEY=VALUE (as gdal_translate -co)", abbreviate(kv, 60));
    }
    if (!list || std::string(list).find("name='" + key + "'") == std::string::npos) {
      CSLDestroy(opts);
      fail("io", "creation option {} is not one the {} driver knows (gdalinfo --format {} lists them)", key, driver,
           driver);
    }
    opts = CSLSetNameValue(opts, key.c_str(), kv.substr(eq + 1).c_str());
  }
  return opts;
}

}  // namespace

// For the vertical units GIS files use; units terracl does not convert are kept as they are,
// and named by `info`.
std::optional<double> metres_per_unit(const std::string& units) {
  std::string u;
  for (unsigned char c : units)
    if (std::isalpha(c)) u += char(std::tolower(c));
  if (u.empty() || u == "m" || u == "metre" || u == "meter" || u == "metres" || u == "meters") return 1.0;
  if (u == "ft" || u == "foot" || u == "feet" || u == "internationalfoot" || u == "footinternational") return 0.3048;
  if (u == "ftus" || u == "usft" || u == "ussurveyfoot" || u == "ussurveyfeet" || u == "footus" || u == "usfoot" ||
      u == "surveyfoot")
    return 1200.0 / 3937.0;
  if (u == "cm" || u == "centimetre" || u == "centimeter" || u == "centimetres" || u == "centimeters") return 0.01;
  if (u == "mm" || u == "millimetre" || u == "millimeter" || u == "millimetres" || u == "millimeters") return 0.001;
  if (u == "dm" || u == "decimetre" || u == "decimeter" || u == "decimetres" || u == "decimeters") return 0.1;
  return std::nullopt;
}

std::optional<WrittenUnit> written_vertical_unit(const Georef& g, const Metadata& md) {
  if (g.vertical_units != "m") return std::nullopt;
  const auto it = md.find("terracl:source_vertical_units");
  if (it == md.end()) return std::nullopt;
  const auto f = metres_per_unit(it->second);
  if (!f || *f == 1.0) return std::nullopt;
  return WrittenUnit{*f, it->second};
}

void set_geotransform_for_writing(GDALDataset& ds, const Georef& g, int height) {
  // A raster without georeferencing (a flat: base, a PNG source) still has metric cells: GDAL,
  // QGIS and GRASS read them from a geotransform, so one is written, with no CRS: the grid
  // covers [0, width * cell_x] x [0, height * cell_y] in metres, north up.
  double gt[6] = {0.0, g.cell_x, 0.0, g.cell_y * height, 0.0, -g.cell_y};
  if (g.has_geotransform) std::copy(g.geotransform.begin(), g.geotransform.end(), gt);
  ds.SetGeoTransform(gt);
}

void init_gdal() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    CPLSetErrorHandler(quiet_handler);
    // GDAL's block cache defaults to 5 % of RAM, and whole-raster reads and writes leave every
    // block in it: an 8193^2 convert peaked at 3.3 copies of the raster. 32 MB (128 blocks of
    // 256^2 floats) holds the blocks in flight, compressed in parallel; a larger cache only holds
    // a written raster's second copy until the file is closed (128 MB: 8193^2 convert 466 MB
    // against 368 MB, no faster). GDAL_CACHEMAX (environment or --config) still decides when set.
    if (!CPLGetConfigOption("GDAL_CACHEMAX", nullptr)) GDALSetCacheMax64(GIntBig(32) << 20);
    // A read that spans several compressed GeoTIFF blocks decodes them on every core (GDAL >= 3.6;
    // the cells are the same). The streamed render's nodata scan and its strips were one thread
    // inflating DEFLATE: an 8193^2 colour relief 5.2 s, now 3.3 s (gdaldem 3.45 s). A
    // GDAL_NUM_THREADS of the user's (environment or --config) still decides when set.
    if (!CPLGetConfigOption("GDAL_NUM_THREADS", nullptr)) CPLSetConfigOption("GDAL_NUM_THREADS", "ALL_CPUS");
  });
}

std::string last_gdal_error() {
  const char* m = CPLGetLastErrorMsg();
  return (m && *m) ? std::string(m) : std::string("no details from GDAL");
}

GdalFirstError::GdalFirstError() { CPLPushErrorHandlerEx(&GdalFirstError::handle, this); }
GdalFirstError::~GdalFirstError() { CPLPopErrorHandler(); }

void CPL_STDCALL GdalFirstError::handle(CPLErr e, CPLErrorNum, const char* m) {
  auto* self = static_cast<GdalFirstError*>(CPLGetErrorHandlerUserData());
  if (e >= CE_Failure && self->m_first.empty() && m && *m) self->m_first = m;
}

std::string GdalFirstError::message() const { return m_first.empty() ? last_gdal_error() : m_first; }

void read_gdal_header(GDALDataset& dataset, Heightfield& out) {
  GDALDataset* ds = &dataset;
  GDALRasterBand* band = ds->GetRasterBand(1);
  const int w = ds->GetRasterXSize(), h = ds->GetRasterYSize();
  Georef& g = out.georef;
  int has_nodata = 0;
  const double nd = band->GetNoDataValue(&has_nodata);
  if (has_nodata) g.nodata = nd;
  double gt[6];
  if (ds->GetGeoTransform(gt) == CE_None && !is_local_geotransform(*ds, gt)) {
    std::copy(gt, gt + 6, g.geotransform.begin());
    g.has_geotransform = true;
  }
  if (const OGRSpatialReference* srs = ds->GetSpatialRef()) {
    char* wkt = nullptr;
    if (srs->exportToWkt(&wkt) == OGRERR_NONE && wkt) g.crs_wkt = wkt;
    CPLFree(wkt);
    g.geographic = srs->IsGeographic();
  }
  if (g.crs_wkt.empty() && g.has_geotransform && looks_like_degrees(g.geotransform, w, h)) {
    // ESRI ASCII grids often come without a .prj; SRTM extracts are in degrees on WGS 84. Assume
    // it, so metric cell sizes are right, and say so in the metadata.
    OGRSpatialReference wgs84;
    wgs84.SetWellKnownGeogCS("WGS84");
    char* wkt = nullptr;
    if (wgs84.exportToWkt(&wkt) == OGRERR_NONE && wkt) g.crs_wkt = wkt;
    CPLFree(wkt);
    g.geographic = true;
    out.metadata["terracl:crs_assumed"] = "WGS 84 (the file has no CRS; its coordinates look like degrees)";
  }
  if (const char* units = band->GetUnitType(); units && *units) {
    // Elevations are metres in memory: a band in feet (or cm, ...) is converted on read
    // (apply_band_scaling), and the unit it had is kept for provenance.
    if (const auto f = metres_per_unit(units); f && *f != 1.0) {
      g.vertical_units = "m";
      out.metadata["terracl:source_vertical_units"] = units;
    } else {
      g.vertical_units = units;
    }
  }
  g.update_metric_cell_size(w, h);
  // A projected CRS in feet (US State Plane): the geotransform is in feet, the cell size in metres.
  if (const OGRSpatialReference* srs = ds->GetSpatialRef(); srs && srs->IsProjected()) {
    const double metres_per_unit = srs->GetLinearUnits();
    if (metres_per_unit > 0 && metres_per_unit != 1.0) {
      g.cell_x *= metres_per_unit;
      g.cell_y *= metres_per_unit;
    }
  }
  if (char** md = ds->GetMetadata()) {
    for (char** p = md; *p; ++p) {
      std::string kv(*p);
      auto eq = kv.find('=');
      // GDAL treats ':' as a key/value separator, so keys are stored as terracl_<name>.
      if (eq != std::string::npos && kv.rfind("terracl_", 0) == 0)
        out.metadata["terracl:" + kv.substr(8, eq - 8)] = kv.substr(eq + 1);
    }
  }
}

void apply_band_scaling(GDALRasterBand& band, Heightfield& h) {
  // GDAL's convention: nodata is a raw value (compared before scaling, convert_nodata), and the
  // value a cell means is raw * scale + offset in the band's unit.
  int has_scale = 0, has_offset = 0;
  const double scale = band.GetScale(&has_scale), offset = band.GetOffset(&has_offset);
  const char* units = band.GetUnitType();
  const double to_metres = metres_per_unit(units ? units : "").value_or(1.0);
  const double a = (has_scale ? scale : 1.0) * to_metres, b = (has_offset ? offset : 0.0) * to_metres;
  if (a == 1.0 && b == 0.0) return;
  if (!std::isfinite(a) || !std::isfinite(b))
    fail("io", "band 1 has scale {} and offset {} (unit '{}'); expected a finite scale and offset",
         has_scale ? scale : 1.0, has_offset ? offset : 0.0, units ? units : "");
  for (float& v : h.z)
    if (std::isfinite(v)) v = float(double(v) * a + b);
}

void convert_nodata(Heightfield& out) {
  if (!out.georef.nodata) return;
  const double nd = *out.georef.nodata;
  const float ndf = float(nd);
  for (float& v : out.z)
    if (v == ndf || (std::isnan(nd) && std::isnan(v))) v = NAN;
}

void check_tiff_blocks(GDALDataset& ds, const std::string& path) {
  if (!ds.GetDriver() || std::string(ds.GetDriver()->GetDescription()) != "GTiff" || ds.GetRasterCount() < 1) return;
  GDALRasterBand* band = ds.GetRasterBand(1);
  int bx = 0, by = 0;
  band->GetBlockSize(&bx, &by);
  const int64_t w = ds.GetRasterXSize(), h = ds.GetRasterYSize();
  // GDAL (libtiff) allocates one decoded block before reading it: a 12 x 9 file claiming
  // 32768 x 16384 tiles took 2.2 GB and 10 s to fail (fuzz_raster). A block may exceed the raster
  // (tiles are padded to multiples of 16; a COG keeps 512 x 512 tiles on a tiny raster), by so much
  // only in a damaged file.
  const double cell_bytes = std::max(1, GDALGetDataTypeSizeBytes(band->GetRasterDataType())) * double(ds.GetRasterCount());
  const double block_bytes = double(bx) * double(by) * cell_bytes, raster_bytes = double(w) * double(h) * cell_bytes;
  if (bx <= 0 || by <= 0 || block_bytes > std::max(64.0 * 1024 * 1024, 4 * raster_bytes))
    fail("io", "{}: the TIFF claims {} x {} cell blocks ({}) for a {} x {} raster; the file is damaged", path, bx, by,
         human_bytes(block_bytes), w, h);
  // Every block's offset and byte count must lie inside the file: libtiff trusts a count
  // before reading. Up to a million blocks (a 65536^2 raster of 64 x 64 tiles); more are rare
  // and libtiff then reads what is there.
  std::error_code ec;
  const uintmax_t file_size = std::filesystem::file_size(path, ec);
  if (ec) return;  // not a plain file (/vsi..., a pipe): GDAL reads it as it can
  const int64_t nx = (w + bx - 1) / bx, ny = (h + by - 1) / by;
  if (nx * ny > 1000000) return;
  for (int64_t y = 0; y < ny; ++y)
    for (int64_t x = 0; x < nx; ++x) {
      const std::string key = fmt::format("{}_{}", x, y);
      const char* off = band->GetMetadataItem(("BLOCK_OFFSET_" + key).c_str(), "TIFF");
      const char* size = band->GetMetadataItem(("BLOCK_SIZE_" + key).c_str(), "TIFF");
      if (!off || !size) continue;  // a sparse (absent) block reads as nodata
      const unsigned long long o = std::strtoull(off, nullptr, 10), n = std::strtoull(size, nullptr, 10);
      if (o > file_size || n > file_size - o)
        fail("io", "{}: TIFF block ({}, {}) claims {} bytes at offset {}, and the file has {} bytes; the file is damaged "
             "or truncated", path, x, y, n, o, file_size);
    }
}

std::optional<std::pair<int64_t, int64_t>> raster_header_size(const std::string& path) {
  // Only files with a raster extension: GDALOpen probes every driver, and a pipeline names
  // sketches, meshes and reports too. EXR headers and PNG chunk lengths are checked first
  // (OpenEXR and libpng trust them).
  const FileFormat f = format_from_extension(path);
  if (f == FileFormat::Unknown || f == FileFormat::RAW16) return std::nullopt;
  try {
    if (f == FileFormat::EXR) check_exr_header(path);
    if (f == FileFormat::PNG) check_png_chunks(path);
  } catch (const Error&) {
    return std::nullopt;  // the reader reports it
  }
  init_gdal();
  CPLErrorReset();
  DatasetPtr ds(static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!ds || ds->GetRasterXSize() <= 0 || ds->GetRasterYSize() <= 0) return std::nullopt;
  return std::make_pair(int64_t(ds->GetRasterXSize()), int64_t(ds->GetRasterYSize()));
}

Heightfield read_gdal(const std::string& path) {
  init_gdal();
  CPLErrorReset();
  DatasetPtr ds(static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!ds) {
    VSIStatBufL st;
    if (is_virtual_path(path) && VSIStatL(path.c_str(), &st) != 0)
      throw MissingFileError(
          "io", fmt::format("{}: no such file in GDAL's virtual file system (gdalinfo {} would say the same)", path, path),
          path);
    fail("io", "{}: not a raster GDAL can read ({})", path, last_gdal_error());
  }
  if (ds->GetRasterXSize() > 0 && ds->GetRasterYSize() > 0)
    require_raster_size("io", path, ds->GetRasterXSize(), ds->GetRasterYSize(), 8);  // before counting its blocks
  check_tiff_blocks(*ds, path);
  // A gradient GeoTIFF (gradient_tiff.cpp) is not a heightfield, as a two-channel EXR is not.
  if (is_gradient_tiff(*ds))
    fail("io", "{}: is a gradient field (2 bands, gx and gy), not a heightfield; reconstruct it first "
         "(terracl reconstruct --gradient {} -o height.tif)", path, path);
  check_single_band(*ds, path);
  return from_dataset(*ds, path);
}

bool is_gradient_tiff(GDALDataset& ds) {
  return ds.GetRasterCount() == 2 && std::string(ds.GetRasterBand(1)->GetDescription()) == "gx" &&
         std::string(ds.GetRasterBand(2)->GetDescription()) == "gy";
}

void check_single_band(GDALDataset& ds, const std::string& path) {
  if (const int n = ds.GetRasterCount(); n > 1)
    fail("io", "{}: has {} bands; terracl reads single-band elevation rasters: pick the elevation band first "
         "(gdal_translate -b 1 {} elevation.tif)", path, n, path);
  if (ds.GetRasterCount() == 1 && GDALDataTypeIsComplex(ds.GetRasterBand(1)->GetRasterDataType()))
    fail("io", "{}: holds complex numbers ({}); terracl reads real-valued elevations: convert it first "
         "(gdal_translate -ot Float32 {} elevation.tif keeps the real part)", path,
         GDALGetDataTypeName(ds.GetRasterBand(1)->GetRasterDataType()), path);
}

Heightfield from_dataset(GDALDataset& dsr, const std::string& path) {
  GDALDataset* ds = &dsr;
  const int w = ds->GetRasterXSize(), h = ds->GetRasterYSize();
  if (w <= 0 || h <= 0 || ds->GetRasterCount() < 1)
    fail("io", "{}: raster has no cells ({} x {}, {} bands)", path, w, h, ds->GetRasterCount());
  require_raster_size("io", path, w, h, 8);  // before allocating: a header may claim 10^6 x 10^6
  Heightfield out(w, h);
  GDALRasterBand* band = ds->GetRasterBand(1);
  if (band->RasterIO(GF_Read, 0, 0, w, h, out.z.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("io", "{}: reading band 1 failed ({})", path, last_gdal_error());
  read_gdal_header(*ds, out);
  convert_nodata(out);
  try {
    apply_band_scaling(*band, out);
  } catch (const Error& e) {
    fail("io", "{}: {}", path, std::string(e.what()).substr(e.stage().size() + 2));
  }
  return out;
}

DatasetPtr to_mem_dataset(const Heightfield& h, GDALDataType type, bool source_units) {
  init_gdal();
  CPLErrorReset();
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  if (!mem) fail("io", "GDAL has no MEM driver");
  const Georef& g = h.georef;
  const bool is_int = GDALDataTypeIsInteger(type);
  // Float32 with NaN (or no) nodata: the band is the heightfield's own cells, not a copy (an 8193^2
  // write held 268 MB twice). Otherwise the MEM band has the output's type and GDAL converts.
  const std::optional<WrittenUnit> unit = source_units ? written_vertical_unit(g, h.metadata) : std::nullopt;
  const bool borrow = type == GDT_Float32 && !unit && !(g.nodata && !std::isnan(*g.nodata) && h.count_nodata() > 0);
  DatasetPtr ds(mem->Create("", h.width, h.height, borrow ? 0 : 1, type, nullptr));
  if (!ds) fail("io", "cannot create an in-memory raster of {} x {} ({})", h.width, h.height, last_gdal_error());
  if (borrow) {
    char** o = CSLSetNameValue(nullptr, "DATAPOINTER", fmt::format("{}", static_cast<const void*>(h.z.data())).c_str());
    const CPLErr added = ds->AddBand(GDT_Float32, o);
    CSLDestroy(o);
    if (added != CE_None) fail("io", "cannot wrap a raster of {} x {} for GDAL ({})", h.width, h.height, last_gdal_error());
  }
  set_geotransform_for_writing(*ds, g, h.height);
  if (!g.crs_wkt.empty()) ds->SetProjection(g.crs_wkt.c_str());
  GDALRasterBand* band = ds->GetRasterBand(1);
  std::vector<float> data;
  const std::vector<float>* src = &h.z;
  if (unit) {
    data = h.z;
    for (float& v : data) v = from_metres(v, unit->metres_per_unit);  // NaN stays NaN
    src = &data;
  }
  if (g.nodata || h.count_nodata() > 0) {
    double nd = g.nodata ? *g.nodata : double(NAN);
    // An integer band cannot hold NaN, nor a value outside its range (-32768 in UInt16): the
    // type's conventional code then.
    const double tmin = type == GDT_UInt16 ? 0.0 : type == GDT_Int16 ? -32768.0 : -2147483648.0;
    const double tmax = type == GDT_UInt16 ? 65535.0 : type == GDT_Int16 ? 32767.0 : 2147483647.0;
    if (is_int && !(nd >= tmin && nd <= tmax && nd == std::round(nd)))
      nd = type == GDT_UInt16 ? 65535.0 : tmin;
    band->SetNoDataValue(nd);
    if (!std::isnan(nd) && h.count_nodata() > 0) {
      if (src != &data) data = h.z;
      for (float& v : data)
        if (!std::isfinite(v)) v = float(nd);
      src = &data;
    }
  }
  band->SetUnitType(unit ? unit->name.c_str() : g.vertical_units.c_str());
  for (const auto& [k, v] : h.metadata) {
    std::string key = k;
    for (char& c : key)
      if (c == ':') c = '_';  // GDAL would split "terracl:x" at the colon
    ds->SetMetadataItem(key.c_str(), v.c_str());
  }
  ds->SetMetadataItem("TIFFTAG_SOFTWARE", ("terracl " + std::string(h.metadata.count("terracl:version") ? h.metadata.at("terracl:version") : "")).c_str());
  ds->SetMetadataItem("terracl_cell_x", fmt::format("{:.17g}", g.cell_x).c_str());
  ds->SetMetadataItem("terracl_cell_y", fmt::format("{:.17g}", g.cell_y).c_str());
  // GDAL rounds float -> integer to the nearest and clamps to the type's range.
  if (!borrow && band->RasterIO(GF_Write, 0, 0, h.width, h.height, const_cast<float*>(src->data()), h.width, h.height, GDT_Float32,
                     0, 0) != CE_None)
    fail("io", "filling an in-memory raster failed ({})", last_gdal_error());
  return ds;
}

void write_geotiff(const Heightfield& h, const std::string& tmp_path, const WriteOptions& wo) {
  init_gdal();
  const GDALDataType type = output_band_type(wo);
  const char* driver = wo.cog ? "COG" : "GTiff";
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver);
  if (!drv) fail("io", "GDAL has no {} driver", driver);
  DatasetPtr mem = to_mem_dataset(h, type, true);  // before the option list: it may throw
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
  opts = CSLSetNameValue(opts, "PREDICTOR", GDALDataTypeIsInteger(type) ? "2" : "3");
  // DEFLATE's fastest level (kDeflateLevel); --co ZLEVEL= (COG: LEVEL=) overrides.
  opts = CSLSetNameValue(opts, wo.cog ? "LEVEL" : "ZLEVEL", std::to_string(kDeflateLevel).c_str());
  if (!wo.cog) opts = CSLSetNameValue(opts, "TILED", "YES");  // COG is always tiled (no such option)
  opts = CSLSetNameValue(opts, "BIGTIFF", "IF_SAFER");
  // DEFLATE on every core (GDAL compresses blocks in parallel; the bytes are the same): 4.3 s of an
  // 8193^2 slope write was single-threaded compression.
  opts = CSLSetNameValue(opts, "NUM_THREADS", "ALL_CPUS");
  opts = add_creation_options(opts, *drv, driver, wo);
  GdalFirstError first;
  auto gdal_error = [&] { return name_output(first.message(), tmp_path); };
  CPLErrorReset();
  // GDAL calls this between the blocks it compresses and writes; FALSE makes CreateCopy stop (a
  // Ctrl-C during a seconds-long LZMA write used to wait for the whole file, then exit 0).
  const GDALProgressFunc on_progress = [](double, const char*, void*) -> int { return stop_requested() ? FALSE : TRUE; };
  GDALDataset* out = drv->CreateCopy(tmp_path.c_str(), mem.get(), FALSE, opts, on_progress, nullptr);
  CSLDestroy(opts);
  if (stop_requested()) {
    if (out) GDALClose(out);
    throw Cancelled("io", "the GeoTIFF write was stopped (Ctrl-C); no output was written");
  }
  if (!out) fail("io", "cannot write GeoTIFF {} ({})", output_name(tmp_path), gdal_error());
  CPLErrorReset();
  GDALClose(out);
  if (CPLGetLastErrorType() >= CE_Failure)
    fail("io", "writing GeoTIFF {} failed ({})", output_name(tmp_path), gdal_error());
  // Closing flushes the last blocks, after GDAL's last callback: a stop asked then still wins.
  if (stop_requested())
    throw Cancelled("io", "the GeoTIFF write was stopped (Ctrl-C); no output was written");
}

}  // namespace terracl::io

namespace terracl::io {

}  // namespace terracl::io

namespace terracl {

std::string stored_band_type(const std::string& path) {
  const FileFormat f = format_from_extension(path);
  if (f == FileFormat::PNG || f == FileFormat::EXR || f == FileFormat::RAW16 || f == FileFormat::NPY) return {};
  io::init_gdal();
  CPLErrorReset();
  io::DatasetPtr ds(
      static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!ds || ds->GetRasterCount() != 1) return {};
  GDALRasterBand* band = ds->GetRasterBand(1);
  const GDALDataType t = band->GetRasterDataType();
  if (t != GDT_Int16 && t != GDT_UInt16 && t != GDT_Int32 && t != GDT_Float64) return {};
  // Values changed on read (scale, offset) are no longer the stored integers. Feet are converted
  // back on write (io::written_vertical_unit), so they keep their type.
  if (band->GetScale() != 1.0 || band->GetOffset() != 0.0) return {};
  return GDALGetDataTypeName(t);
}

}  // namespace terracl

namespace terracl::io {

std::string gdal_driver_for_output(const std::string& path, const std::string& asked) {
  init_gdal();
  GDALDriverManager* dm = GetGDALDriverManager();
  auto can_write = [](GDALDriver* d) {
    return d->GetMetadataItem(GDAL_DCAP_RASTER) &&
           (d->GetMetadataItem(GDAL_DCAP_CREATECOPY) || d->GetMetadataItem(GDAL_DCAP_CREATE));
  };
  if (!asked.empty()) {
    GDALDriver* d = dm->GetDriverByName(asked.c_str());
    if (!d) fail("io", "{}: GDAL has no driver named '{}' (gdalinfo --formats lists them)", path, abbreviate(asked, 40));
    if (!can_write(d)) fail("io", "{}: GDAL's {} driver cannot write rasters (gdalinfo --formats: rw)", path, asked);
    return asked;
  }
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty()) ext = ext.substr(1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::vector<std::string> found;
  for (int i = 0; i < dm->GetDriverCount() && !ext.empty(); ++i) {
    GDALDriver* d = dm->GetDriver(i);
    const char* exts = d->GetMetadataItem(GDAL_DMD_EXTENSIONS);
    if (!exts || !can_write(d)) continue;
    std::string list = std::string(" ") + exts + " ";
    std::transform(list.begin(), list.end(), list.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (list.find(" " + ext + " ") != std::string::npos) found.push_back(d->GetDescription());
  }
  // Several drivers claim a few extensions (.grd: GSAG, GSBG, NWT_GRD); GDAL's own programs ask
  // for -of then, and so does terracl.
  if (found.size() == 1) return found[0];
  if (found.empty())
    fail("io", "{}: no GDAL driver writes rasters with the extension '.{}'; name one with --of (gdalinfo --formats "
         "lists those marked rw)", path, ext);
  fail("io", "{}: several GDAL drivers write '.{}' ({}); choose one with --of", path, ext, fmt::join(found, ", "));
}

std::vector<std::string> write_gdal_copy(const Heightfield& h, const std::string& tmp_path, const std::string& driver,
                                         const WriteOptions& wo) {
  init_gdal();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver.c_str());
  if (!drv) fail("io", "GDAL has no {} driver", driver);
  const GDALDataType type = output_band_type(wo);
  DatasetPtr mem = to_mem_dataset(h, type, true);  // before the option list: it may throw
  char** opts = add_creation_options(nullptr, *drv, driver, wo);
  GdalFirstError first;
  CPLErrorReset();
  GDALDataset* out = drv->CreateCopy(tmp_path.c_str(), mem.get(), FALSE, opts, nullptr, nullptr);
  CSLDestroy(opts);
  if (!out) fail("io", "cannot write {} as {} ({})", output_name(tmp_path), driver, name_output(first.message(), tmp_path));
  // Formats of several files (a .prj beside an .asc, a .hdr beside a .bil): all of them are
  // renamed into place with the main file.
  std::vector<std::string> files;
  if (char** list = out->GetFileList()) {
    for (char** p = list; *p; ++p) files.emplace_back(*p);
    CSLDestroy(list);
  }
  CPLErrorReset();
  GDALClose(out);
  if (CPLGetLastErrorType() >= CE_Failure)
    fail("io", "writing {} as {} failed ({})", output_name(tmp_path), driver, name_output(first.message(), tmp_path));
  return files;
}

}  // namespace terracl::io
