// Windowed GDAL reading and writing (gdal_window.hpp). The header (georef, nodata, metadata) is
// read by the same code as a whole-raster read, so a tile carries exactly what the untiled run
// would see; only the geotransform moves to the window.
#include "io/gdal_window.hpp"
#include "io/gdal_common.hpp"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <fmt/format.h>
#include <gdal_priv.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <terracl/error.hpp>
#include <utility>

#include "io/io_common.hpp"

namespace terracl::io {

GdalWindowReader::GdalWindowReader(const std::string& path) : m_path(path) {
  init_gdal();
  CPLErrorReset();
  m_ds =
      static_cast<GDALDataset*>(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!m_ds) fail("io", "{}: not a raster GDAL can read ({})", path, last_gdal_error());
  const int w = m_ds->GetRasterXSize(), h = m_ds->GetRasterYSize();
  if (w <= 0 || h <= 0 || m_ds->GetRasterCount() < 1) {
    GDALClose(m_ds);
    fail("io", "{}: raster has no cells ({} x {})", path, w, h);
  }
  try {
    check_tiff_blocks(*m_ds, path);  // a damaged block table: refused before GDAL allocates a block
  } catch (...) {
    GDALClose(m_ds);
    throw;
  }
  m_header.width = w;
  m_header.height = h;
  read_gdal_header(*m_ds, m_header);
  // As read_heightfield: our own non-georeferenced GeoTIFFs keep their metric cell size as metadata.
  if (!m_header.georef.has_geotransform) {
    for (auto [key, v] :
         {std::pair{"terracl:cell_x", &m_header.georef.cell_x}, {"terracl:cell_y", &m_header.georef.cell_y}})
      if (auto it = m_header.metadata.find(key); it != m_header.metadata.end()) {
        const double d = std::strtod(it->second.c_str(), nullptr);
        if (std::isfinite(d) && d > 0) *v = d;
      }
  }
  m_header.metadata.erase("terracl:cell_x");
  m_header.metadata.erase("terracl:cell_y");
}

GdalWindowReader::~GdalWindowReader() {
  if (m_ds) GDALClose(m_ds);
}

Heightfield GdalWindowReader::read(int x, int y, int w, int h, int band) const {
  if (band < 1 || band > m_ds->GetRasterCount()) fail("io", "{}: has no band {}", m_path, band);
  if (x < 0 || y < 0 || w < 1 || h < 1 || x + w > width() || y + h > height())
    fail("io", "{}: window {},{} {} x {} outside the {} x {} raster", m_path, x, y, w, h, width(), height());
  Heightfield out(w, h);
  out.georef = m_header.georef;
  out.metadata = m_header.metadata;
  CPLErrorReset();
  if (m_ds->GetRasterBand(band)->RasterIO(GF_Read, x, y, w, h, out.z.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("io", "{}: reading window {},{} {} x {} failed ({})", m_path, x, y, w, h, last_gdal_error());
  convert_nodata(out);
  auto& gt = out.georef.geotransform;
  if (out.georef.has_geotransform) {
    gt[0] += x * gt[1] + y * gt[2];
    gt[3] += x * gt[4] + y * gt[5];
  }
  return out;
}

int GdalWindowReader::bands() const { return m_ds->GetRasterCount(); }

std::string GdalWindowReader::band_description(int band) const {
  if (band < 1 || band > bands()) return {};
  const char* d = m_ds->GetRasterBand(band)->GetDescription();
  return d ? d : "";
}

void GdalWindowReader::release_cache() const { m_ds->FlushCache(); }

uint64_t window_checksum(const float* cells, size_t n) {
  uint64_t h = 1469598103934665603ull;
  const auto* b = reinterpret_cast<const unsigned char*>(cells);
  for (size_t i = 0; i < n * sizeof(float); ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

GeoTiffWindowWriter::GeoTiffWindowWriter(const std::string& path, int width, int height, const Georef& g,
                                         const Metadata& metadata, const std::string& partial, int bands)
    : m_path(path),
      m_tmp(partial.empty() ? temporary_path_for(path) : partial),
      m_resumable(!partial.empty()),
      m_nodata(g.nodata) {
  m_bands = bands;
  init_gdal();
  CPLErrorReset();
  if (m_resumable) {
    // A partial output of an interrupted run: reopened for update when it is the raster this
    // writer would create (the journal then says which windows it holds), else recreated.
    std::error_code ec;
    if (std::filesystem::exists(m_tmp, ec)) {
      m_ds = static_cast<GDALDataset*>(
          GDALOpenEx(m_tmp.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE, nullptr, nullptr, nullptr));
      if (m_ds && (m_ds->GetRasterXSize() != width || m_ds->GetRasterYSize() != height || m_ds->GetRasterCount() != m_bands ||
                   m_ds->GetRasterBand(1)->GetRasterDataType() != GDT_Float32)) {
        GDALClose(m_ds);
        m_ds = nullptr;
      }
      if (m_ds) {
        m_reopened = true;
        return;
      }
      CPLErrorReset();
      std::filesystem::remove(m_tmp, ec);
    }
  }
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!drv) fail("io", "GDAL has no GTiff driver");
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
  opts = CSLSetNameValue(opts, "PREDICTOR", "3");
  opts = CSLSetNameValue(opts, "TILED", "YES");
  opts = CSLSetNameValue(opts, "BLOCKXSIZE", "256");
  opts = CSLSetNameValue(opts, "BLOCKYSIZE", "256");
  // Compressed size is unknown up front: BigTIFF as soon as the uncompressed raster could pass 4 GB.
  opts = CSLSetNameValue(opts, "BIGTIFF", double(width) * height * 4 > 3.5e9 ? "YES" : "IF_SAFER");
  // A resumable output is closed after every tile (flush()): without SPARSE_OK each close would
  // first write every block not yet written.
  if (m_resumable) opts = CSLSetNameValue(opts, "SPARSE_OK", "TRUE");
  // A gradient's two bands are written one after the other per window: each in blocks of its own.
  if (m_bands > 1) opts = CSLSetNameValue(opts, "INTERLEAVE", "BAND");
  m_ds = drv->Create(m_tmp.c_str(), width, height, m_bands, GDT_Float32, opts);
  CSLDestroy(opts);
  if (!m_ds) {
    if (!m_resumable) discard_temporary(m_tmp);
    fail("io", "cannot create GeoTIFF {} ({})", path, last_gdal_error());
  }
  if (g.has_geotransform) {
    double gt[6];
    std::copy(g.geotransform.begin(), g.geotransform.end(), gt);
    m_ds->SetGeoTransform(gt);
  }
  if (!g.crs_wkt.empty()) m_ds->SetProjection(g.crs_wkt.c_str());
  for (int b = 1; b <= m_bands; ++b) {
    GDALRasterBand* band = m_ds->GetRasterBand(b);
    if (m_nodata) band->SetNoDataValue(*m_nodata);
    band->SetUnitType(g.vertical_units.c_str());
    if (m_bands == 2) band->SetDescription(b == 1 ? "gx" : "gy");  // what read_gradient looks for
  }
  // The same items as write_geotiff, so a tiled output reads back like an untiled one.
  for (const auto& [k, v] : metadata) {
    std::string key = k;
    for (char& c : key)
      if (c == ':') c = '_';
    m_ds->SetMetadataItem(key.c_str(), v.c_str());
  }
  m_ds->SetMetadataItem(
      "TIFFTAG_SOFTWARE",
      ("terracl " + std::string(metadata.count("terracl:version") ? metadata.at("terracl:version") : "")).c_str());
  m_ds->SetMetadataItem("terracl_cell_x", fmt::format("{:.17g}", g.cell_x).c_str());
  m_ds->SetMetadataItem("terracl_cell_y", fmt::format("{:.17g}", g.cell_y).c_str());
}

GeoTiffWindowWriter::~GeoTiffWindowWriter() {
  if (m_ds) {
    GDALClose(m_ds);
    if (!m_resumable) discard_temporary(m_tmp);  // a partial output stays for --resume
  }
}

uint64_t GeoTiffWindowWriter::write(int x, int y, const Heightfield& src, int sx, int sy, int w, int h, int band) {
  if (!m_ds) fail("io", "{}: written after commit", m_path);
  if (w < 1 || h < 1) return window_checksum(nullptr, 0);
  m_buffer.resize(size_t(w) * h);
  const float nd = m_nodata ? float(*m_nodata) : NAN;
  for (int r = 0; r < h; ++r) {
    const float* in = &src.z[size_t(sy + r) * src.width + sx];
    float* out = &m_buffer[size_t(r) * w];
    for (int c = 0; c < w; ++c) {
      float v = in[c];
      if (!std::isfinite(v)) {
        m_any_nan = true;
        v = nd;
      }
      out[c] = v;
    }
  }
  CPLErrorReset();
  if (m_ds->GetRasterBand(band)->RasterIO(GF_Write, x, y, w, h, m_buffer.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("io", "writing GeoTIFF {} failed at window {},{} ({})", m_path, x, y, last_gdal_error());
  return window_checksum(m_buffer.data(), m_buffer.size());
}

uint64_t GeoTiffWindowWriter::checksum(int x, int y, int w, int h, int band) {
  if (!m_ds) fail("io", "{}: read after commit", m_path);
  if (w < 1 || h < 1) return window_checksum(nullptr, 0);
  m_buffer.resize(size_t(w) * h);
  CPLErrorReset();
  if (m_ds->GetRasterBand(band)->RasterIO(GF_Read, x, y, w, h, m_buffer.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("io", "{}: reading back window {},{} {} x {} failed ({})", m_tmp, x, y, w, h, last_gdal_error());
  // As write(): a NaN stored without a nodata value makes commit() declare NaN as nodata.
  if (!m_nodata)
    for (float v : m_buffer)
      if (std::isnan(v)) m_any_nan = true;
  return window_checksum(m_buffer.data(), m_buffer.size());
}

void GeoTiffWindowWriter::set_metadata_item(const std::string& key, const std::string& value) {
  if (!m_ds) fail("io", "{}: metadata after commit", m_path);
  std::string k = key;
  for (char& c : k)
    if (c == ':') c = '_';
  m_ds->SetMetadataItem(k.c_str(), value.c_str());
}

void GeoTiffWindowWriter::flush() {
  if (!m_ds) return;
  // FlushCache() leaves the last bytes in the stdio buffer of GDAL's file handle (a killed process
  // loses them: a truncated block), so the file is closed, which writes everything, and reopened.
  CPLErrorReset();
  GDALClose(m_ds);
  m_ds = nullptr;
  if (CPLGetLastErrorType() >= CE_Failure) fail("io", "{}: flushing to disk failed ({})", m_tmp, last_gdal_error());
  m_ds =
      static_cast<GDALDataset*>(GDALOpenEx(m_tmp.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE, nullptr, nullptr, nullptr));
  if (!m_ds) fail("io", "{}: reopening after a flush failed ({})", m_tmp, last_gdal_error());
}

void GeoTiffWindowWriter::commit() {
  if (!m_ds) fail("io", "{}: committed twice", m_path);
  // As write_geotiff: NaN cells without a nodata value of the source get NaN as nodata.
  if (!m_nodata && m_any_nan)
    for (int b = 1; b <= m_bands; ++b) m_ds->GetRasterBand(b)->SetNoDataValue(double(NAN));
  GDALDataset* raw = m_ds;
  m_ds = nullptr;
  CPLErrorReset();
  GDALClose(raw);
  if (CPLGetLastErrorType() >= CE_Failure) {
    discard_temporary(m_tmp);
    fail("io", "finishing GeoTIFF {} failed ({})", m_path, last_gdal_error());
  }
  commit_temporary(m_tmp, m_path);
}

}  // namespace terracl::io
