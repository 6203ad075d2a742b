// SPDX-License-Identifier: Apache-2.0
// Windowed GDAL reading and writing (gdal_window.hpp). The header (georef, nodata, metadata) is
// read by the same code as a whole-raster read, so a tile carries exactly what the untiled run
// would see; only the geotransform moves to the window.
#include "io/gdal_window.hpp"

#include <terracl/amplify.hpp>  // parallel_for

#include <cpl_conv.h>
#include <cpl_error.h>
#include <fmt/format.h>
#include <gdal_priv.h>
#include <tiffio.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <terracl/error.hpp>
#include <utility>

#include "io/gdal_common.hpp"
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

namespace terracl::io {
namespace {

// The windowed writer's GeoTIFF layout, for the file it writes and for the compacted copy of a
// resumed one: deflate with the float predictor in 256^2 tiles.
char** block_tiff_options(double width, double height, int bands, bool compress = true) {
  char** opts = nullptr;
  if (compress) {
    opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
    opts = CSLSetNameValue(opts, "PREDICTOR", "3");
    opts = CSLSetNameValue(opts, "ZLEVEL", std::to_string(kDeflateLevel).c_str());
  }
  opts = CSLSetNameValue(opts, "TILED", "YES");
  opts = CSLSetNameValue(opts, "BLOCKXSIZE", "256");
  opts = CSLSetNameValue(opts, "BLOCKYSIZE", "256");
  // Compressed size is unknown up front: BigTIFF as soon as the uncompressed raster could pass 4 GB.
  opts = CSLSetNameValue(opts, "BIGTIFF", width * height * 4 * bands > 3.5e9 ? "YES" : "IF_SAFER");
  // A gradient's two bands are written one after the other per window: each in blocks of its own.
  if (bands > 1) opts = CSLSetNameValue(opts, "INTERLEAVE", "BAND");
  return opts;
}
constexpr int kBlock = 256;  // the writer's BLOCKXSIZE / BLOCKYSIZE
}  // namespace

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
    if (!is_gradient_tiff(*m_ds)) check_single_band(*m_ds, path);
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
  try {
    check_cell_size(m_header.georef, path, cell_size_source(m_header.georef, path, false));
  } catch (...) {
    GDALClose(m_ds);
    m_ds = nullptr;
    throw;
  }
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
  try {
    apply_band_scaling(*m_ds->GetRasterBand(band), out);
  } catch (const Error& e) {
    fail("io", "{}: {}", m_path, std::string(e.what()).substr(e.stage().size() + 2));
  }
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

double written_metres_per_unit(const Georef& georef, const Metadata& metadata) {
  const auto unit = written_vertical_unit(georef, metadata);
  return unit ? unit->metres_per_unit : 1.0;
}

uint64_t window_checksum(const float* cells, size_t n) {
  uint64_t h = 1469598103934665603ull;
  const auto* b = reinterpret_cast<const unsigned char*>(cells);
  for (size_t i = 0; i < n * sizeof(float); ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

GeoTiffWindowWriter::GeoTiffWindowWriter(const std::string& path, int width, int height, const Georef& g,
                                         const Metadata& metadata, const std::string& partial, int bands,
                                         bool compress)
    : m_path(path),
      m_tmp(partial.empty() ? temporary_path_for(path) : partial),
      m_resumable(!partial.empty()),
      m_compress(compress),
      m_nodata(g.nodata),
      m_metres_per_unit(written_metres_per_unit(g, metadata)) {
  m_width = width;
  m_height = height;
  m_bands = bands;
  m_blocks_x = (width + kBlock - 1) / kBlock;
  m_blocks_y = (height + kBlock - 1) / kBlock;
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
  char** opts = block_tiff_options(width, height, m_bands, m_compress);
  // A resumable output is closed after every tile (flush()): without SPARSE_OK each close would
  // first write every block not yet written.
  // The raw writer's file is created empty (GDAL then writes no block) and libtiff adds the blocks.
  if (m_resumable || m_bands == 1) opts = CSLSetNameValue(opts, "SPARSE_OK", "TRUE");
  m_ds = drv->Create(m_tmp.c_str(), width, height, m_bands, GDT_Float32, opts);
  CSLDestroy(opts);
  if (!m_ds) {
    if (!m_resumable) discard_temporary(m_tmp);
    fail("io", "cannot create GeoTIFF {} ({})", path, name_output(last_gdal_error(), m_tmp));
  }
  set_geotransform_for_writing(*m_ds, g, height);
  if (!g.crs_wkt.empty()) m_ds->SetProjection(g.crs_wkt.c_str());
  for (int b = 1; b <= m_bands; ++b) {
    GDALRasterBand* band = m_ds->GetRasterBand(b);
    if (m_nodata) band->SetNoDataValue(*m_nodata);
    band->SetUnitType(m_metres_per_unit != 1.0 ? metadata.at("terracl:source_vertical_units").c_str()
                                                : g.vertical_units.c_str());
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
  // A gradient (two bands) is written through GDAL like a resumable output: rank 0 compresses it.
  if (!compresses()) return;
  // GDAL writes the header and directory; libtiff reopens the file to append raw blocks, and at
  // close rewrites only the block offsets and sizes in place (the directory stays GDAL's).
  GDALDataset* raw = m_ds;
  m_ds = nullptr;
  GDALClose(raw);
  if (CPLGetLastErrorType() >= CE_Failure) {
    discard_temporary(m_tmp);
    fail("io", "cannot create GeoTIFF {} ({})", path, name_output(last_gdal_error(), m_tmp));
  }
  m_tif = TIFFOpen(m_tmp.c_str(), "r+");
  if (!m_tif) {
    discard_temporary(m_tmp);
    fail("io", "cannot reopen {} to write its blocks ({})", m_path, name_output(last_gdal_error(), m_tmp));
  }
  m_block_written.assign(size_t(m_blocks_x) * size_t(m_blocks_y), 0);
}

GeoTiffWindowWriter::~GeoTiffWindowWriter() {
  if (m_tif) {
    TIFFClose(m_tif);
    discard_temporary(m_tmp);
  }
  if (m_ds) {
    GDALClose(m_ds);
    if (!m_resumable) discard_temporary(m_tmp);  // a partial output stays for --resume
  }
}

uint64_t GeoTiffWindowWriter::write(int x, int y, const Heightfield& src, int sx, int sy, int w, int h, int band) {
  if (!m_ds && !m_tif) fail("io", "{}: written after commit", m_path);
  if (w < 1 || h < 1) return window_checksum(nullptr, 0);
  return put(encode(m_width, m_height, m_nodata, x, y, src, sx, sy, w, h, compresses(), m_metres_per_unit), band);
}

namespace {
// An encoded window: its header, then each whole block (index, size, bytes), then its cells when
// some block is only partly inside it (or nothing is compressed).
struct EncodedHeader {
  uint32_t magic;
  int32_t x, y, w, h;
  uint8_t compressed, any_nan, has_cells, in_other_unit;
  uint64_t checksum;
  uint32_t blocks;
};
constexpr uint32_t kEncodedMagic = 0x4b4c4254;  // "TBLK"

template <class T>
void append(std::vector<uint8_t>& b, const T& v) {
  const auto* p = reinterpret_cast<const uint8_t*>(&v);
  b.insert(b.end(), p, p + sizeof(T));
}
}  // namespace

std::vector<uint8_t> GeoTiffWindowWriter::encode(int width, int height, std::optional<double> nodata, int x, int y,
                                                 const Heightfield& src, int sx, int sy, int w, int h, bool compress,
                                                 double metres_per_unit) {
  if (x < 0 || y < 0 || w < 1 || h < 1 || x + w > width || y + h > height)
    fail("io", "internal: window {},{} {} x {} outside the {} x {} raster", x, y, w, h, width, height);
  std::vector<float> cells(size_t(w) * h);
  const float nd = nodata ? float(*nodata) : NAN;
  bool any_nan = false;
  for (int r = 0; r < h; ++r) {
    const float* in = &src.z[size_t(sy + r) * src.width + sx];
    float* out = &cells[size_t(r) * w];
    for (int c = 0; c < w; ++c) {
      float v = metres_per_unit == 1.0 ? in[c] : from_metres(in[c], metres_per_unit);
      if (!std::isfinite(v)) {
        any_nan = true;
        v = nd;
      }
      out[c] = v;
    }
  }
  EncodedHeader hd{kEncodedMagic,
                   x,
                   y,
                   w,
                   h,
                   uint8_t(compress),
                   uint8_t(any_nan),
                   0,
                   uint8_t(metres_per_unit != 1.0),
                   window_checksum(cells.data(), cells.size()),
                   0};
  std::vector<uint8_t> out(sizeof(EncodedHeader));
  const int bx_n = (width + kBlock - 1) / kBlock;
  bool partial = !compress;
  struct Whole {
    int bx, by;
  };
  std::vector<Whole> whole;  // the blocks wholly inside the window, in row order
  for (int by = y / kBlock; by * kBlock < y + h; ++by)
    for (int bx = x / kBlock; bx * kBlock < x + w; ++bx) {
      const int x0 = bx * kBlock, y0 = by * kBlock;
      const int x1 = std::min(x0 + kBlock, width), y1 = std::min(y0 + kBlock, height);
      if (x0 < x || y0 < y || x1 > x + w || y1 > y + h) {
        partial = true;
        continue;
      }
      if (compress) whole.push_back({bx, by});
    }
  // DEFLATE is most of a window's cost: its blocks are compressed on every core, then appended in
  // row order (a tiled 8193^2 convert compressed on one core: 2.1x the untiled one).
  std::vector<std::vector<uint8_t>> bytes(whole.size());
  parallel_for(whole.size(), whole.size() >= 4 ? 0 : 1, [&](size_t b, size_t e) {
    std::vector<float> block(size_t(kBlock) * kBlock);
    for (size_t k = b; k < e; ++k) {
      const int x0 = whole[k].bx * kBlock, y0 = whole[k].by * kBlock;
      const int x1 = std::min(x0 + kBlock, width), y1 = std::min(y0 + kBlock, height);
      std::fill(block.begin(), block.end(), 0.0f);  // GDAL pads edge blocks with 0
      for (int r = y0; r < y1; ++r)
        std::memcpy(&block[size_t(r - y0) * kBlock], &cells[size_t(r - y) * w + size_t(x0 - x)],
                    size_t(x1 - x0) * sizeof(float));
      bytes[k] = encode_float_block(block.data());
    }
  });
  for (size_t k = 0; k < whole.size(); ++k) {
    append(out, uint32_t(whole[k].by * bx_n + whole[k].bx));
    append(out, uint32_t(bytes[k].size()));
    out.insert(out.end(), bytes[k].begin(), bytes[k].end());
    std::vector<uint8_t>().swap(bytes[k]);
    ++hd.blocks;
  }
  if (partial) {
    hd.has_cells = 1;
    const auto* p = reinterpret_cast<const uint8_t*>(cells.data());
    out.insert(out.end(), p, p + cells.size() * sizeof(float));
  }
  std::memcpy(out.data(), &hd, sizeof hd);
  return out;
}

size_t GeoTiffWindowWriter::block_cells(uint32_t index) const {
  const int bx = int(index % uint32_t(m_blocks_x)), by = int(index / uint32_t(m_blocks_x));
  return size_t(std::min(kBlock, m_width - bx * kBlock)) * size_t(std::min(kBlock, m_height - by * kBlock));
}

void GeoTiffWindowWriter::write_block(uint32_t index, const uint8_t* bytes, size_t n) {
  CPLErrorReset();
  if (TIFFWriteRawTile(m_tif, index, const_cast<uint8_t*>(bytes), tmsize_t(n)) != tmsize_t(n))
    fail("io", "writing GeoTIFF {} failed at block {} ({})", m_path, index, name_output(last_gdal_error(), m_tmp));
  m_block_written[index] = 1;
}

uint64_t GeoTiffWindowWriter::put(const std::vector<uint8_t>& e, int band) {
  if (band < 1 || band > m_bands || (band != 1 && m_tif)) fail("io", "internal: {} has no band {}", m_path, band);
  if (!m_ds && !m_tif) fail("io", "{}: written after commit", m_path);
  EncodedHeader hd{};
  if (e.size() < sizeof hd) fail("io", "internal: encoded window of {} bytes", e.size());
  std::memcpy(&hd, e.data(), sizeof hd);
  if (hd.magic != kEncodedMagic || hd.x < 0 || hd.y < 0 || hd.w < 1 || hd.h < 1 || hd.x + hd.w > m_width ||
      hd.y + hd.h > m_height || (hd.compressed && !m_tif) || (!hd.compressed && !hd.has_cells))
    fail("io", "internal: encoded window {},{} {} x {} does not fit {} ({} x {})", hd.x, hd.y, hd.w, hd.h, m_path,
         m_width, m_height);
  if ((hd.in_other_unit != 0) != (m_metres_per_unit != 1.0))
    fail("io", "internal: window {},{} encoded in {} but {} is written in {}", hd.x, hd.y,
         hd.in_other_unit ? "another unit" : "metres", m_path, m_metres_per_unit != 1.0 ? "another unit" : "metres");
  m_any_nan |= hd.any_nan != 0;
  size_t at = sizeof hd;
  for (uint32_t k = 0; k < hd.blocks; ++k) {
    uint32_t index = 0, n = 0;
    if (e.size() - at < 8) fail("io", "internal: encoded window read past its end");
    std::memcpy(&index, &e[at], 4);
    std::memcpy(&n, &e[at + 4], 4);
    at += 8;
    if (index >= m_block_written.size() || e.size() - at < n) fail("io", "internal: encoded block {} damaged", index);
    write_block(index, &e[at], n);
    m_pending.erase(index);
    at += n;
  }
  const size_t cell_bytes = size_t(hd.w) * size_t(hd.h) * sizeof(float);
  if (hd.has_cells ? e.size() - at != cell_bytes : e.size() != at)
    fail("io", "internal: encoded window of {} bytes, {} expected", e.size(), at + (hd.has_cells ? cell_bytes : 0));
  if (!hd.has_cells) return hd.checksum;
  // Copied out: after blocks of any size the cells need not be aligned for float.
  m_buffer.resize(size_t(hd.w) * size_t(hd.h));
  std::memcpy(m_buffer.data(), &e[at], cell_bytes);
  const float* cells = m_buffer.data();
  if (!m_tif) {  // resumable or two bands: GDAL writes (and reads back the blocks these cells share)
    CPLErrorReset();
    if (m_ds->GetRasterBand(band)->RasterIO(GF_Write, hd.x, hd.y, hd.w, hd.h, m_buffer.data(), hd.w, hd.h, GDT_Float32,
                                            0, 0) != CE_None)
      fail("io", "writing GeoTIFF {} failed at window {},{} ({})", m_path, hd.x, hd.y,
           name_output(last_gdal_error(), m_tmp));
    return hd.checksum;
  }
  // The blocks the window covers in part: its cells join the others' there; a block is compressed
  // as soon as all its cells have come (rank 0 compresses only these).
  for (int by = hd.y / kBlock; by * kBlock < hd.y + hd.h; ++by)
    for (int bx = hd.x / kBlock; bx * kBlock < hd.x + hd.w; ++bx) {
      const auto index = uint32_t(by * m_blocks_x + bx);
      const bool inside = bx * kBlock >= hd.x && by * kBlock >= hd.y &&
                          std::min((bx + 1) * kBlock, m_width) <= hd.x + hd.w &&
                          std::min((by + 1) * kBlock, m_height) <= hd.y + hd.h;
      if (inside && hd.compressed) continue;  // came compressed above
      const int x0 = std::max(bx * kBlock, hd.x), x1 = std::min({(bx + 1) * kBlock, hd.x + hd.w, m_width});
      const int y0 = std::max(by * kBlock, hd.y), y1 = std::min({(by + 1) * kBlock, hd.y + hd.h, m_height});
      Pending& p = m_pending[index];
      // As GDAL starts a block that a write covers in part: nodata everywhere (padding included).
      if (p.cells.empty()) p.cells.assign(size_t(kBlock) * kBlock, m_nodata ? float(*m_nodata) : 0.0f);
      for (int r = y0; r < y1; ++r)
        std::memcpy(&p.cells[size_t(r - by * kBlock) * kBlock + size_t(x0 - bx * kBlock)],
                    &cells[size_t(r - hd.y) * hd.w + size_t(x0 - hd.x)], size_t(x1 - x0) * sizeof(float));
      p.filled += size_t(x1 - x0) * size_t(y1 - y0);
      if (p.filled >= block_cells(index)) {
        const std::vector<uint8_t> bytes = encode_float_block(p.cells.data());
        m_pending.erase(index);
        write_block(index, bytes.data(), bytes.size());
      }
    }
  return hd.checksum;
}

uint64_t GeoTiffWindowWriter::checksum(int x, int y, int w, int h, int band) {
  if (!m_ds) fail("io", "{}: read back after commit or from a writer that is not resumable", m_path);
  if (w < 1 || h < 1) return window_checksum(nullptr, 0);
  m_buffer.resize(size_t(w) * h);
  CPLErrorReset();
  if (m_ds->GetRasterBand(band)->RasterIO(GF_Read, x, y, w, h, m_buffer.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("io", "{}: reading back window {},{} {} x {} failed ({})", m_path, x, y, w, h,
         name_output(last_gdal_error(), m_tmp));
  // As write(): a NaN stored without a nodata value makes commit() declare NaN as nodata.
  if (!m_nodata)
    for (float v : m_buffer)
      if (std::isnan(v)) m_any_nan = true;
  return window_checksum(m_buffer.data(), m_buffer.size());
}

void GeoTiffWindowWriter::set_metadata_item(const std::string& key, const std::string& value) {
  if (!m_ds && !m_tif) fail("io", "{}: metadata after commit", m_path);
  std::string k = key;
  for (char& c : k)
    if (c == ':') c = '_';
  if (m_ds)
    m_ds->SetMetadataItem(k.c_str(), value.c_str());
  else
    m_late_metadata.emplace_back(k, value);
}

void GeoTiffWindowWriter::flush() {
  if (!m_ds) return;
  // FlushCache() leaves the last bytes in the stdio buffer of GDAL's file handle (a killed process
  // loses them: a truncated block), so the file is closed, which writes everything, and reopened.
  CPLErrorReset();
  GDALClose(m_ds);
  m_ds = nullptr;
  if (CPLGetLastErrorType() >= CE_Failure)
    fail("io", "{}: flushing to disk failed ({})", m_path, name_output(last_gdal_error(), m_tmp));
  m_ds =
      static_cast<GDALDataset*>(GDALOpenEx(m_tmp.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE, nullptr, nullptr, nullptr));
  if (!m_ds) fail("io", "{}: reopening after a flush failed ({})", m_path, name_output(last_gdal_error(), m_tmp));
}

void GeoTiffWindowWriter::commit() {
  if (m_tif) {
    commit_raw();
    return;
  }
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
    fail("io", "finishing GeoTIFF {} failed ({})", m_path, name_output(last_gdal_error(), m_tmp));
  }
  if (m_resumable) return commit_compacted();
  commit_temporary(m_tmp, m_path);
}

void GeoTiffWindowWriter::commit_compacted() {
  // A resumable output is closed after every tile; a block that several tiles fill is rewritten
  // each time, and GDAL appends the larger rewrite at the end of the file, leaving the old bytes
  // unused: a --resume output of 16-cell tiles was 24 times a straight run's. When the blocks use
  // under 3/4 of the file, it is copied once more, block by block, into a compact file.
  CPLErrorReset();
  GdalFirstError first;
  DatasetPtr in(static_cast<GDALDataset*>(GDALOpenEx(m_tmp.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr,
                                                     nullptr, nullptr)));
  if (!in) fail("io", "finishing GeoTIFF {} failed ({})", m_path, name_output(first.message(), m_tmp));
  uint64_t used = 0;
  for (int b = 1; b <= m_bands; ++b)
    for (int by = 0; by < m_blocks_y; ++by)
      for (int bx = 0; bx < m_blocks_x; ++bx) {
        const std::string item = fmt::format("BLOCK_SIZE_{}_{}", bx, by);
        if (const char* n = in->GetRasterBand(b)->GetMetadataItem(item.c_str(), "TIFF"))
          used += std::strtoull(n, nullptr, 10);
      }
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(m_tmp, ec);
  if (ec || size <= used + used / 3 + 65536) {
    in.reset();
    commit_temporary(m_tmp, m_path);
    return;
  }
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  char** opts = block_tiff_options(m_width, m_height, m_bands, m_compress);
  const std::string compact = temporary_path_for(m_path);
  GDALDataset* out = drv ? drv->CreateCopy(compact.c_str(), in.get(), FALSE, opts, nullptr, nullptr) : nullptr;
  CSLDestroy(opts);
  if (out) GDALClose(out);
  in.reset();
  if (!out || CPLGetLastErrorType() >= CE_Failure) {
    discard_temporary(compact);
    // The partial file stays: a rerun with --resume finds every tile done and commits again.
    fail("io", "finishing GeoTIFF {} failed ({})", m_path, name_output(first.message(), compact));
  }
  commit_temporary(compact, m_path);
  std::filesystem::remove(m_tmp, ec);
}

void GeoTiffWindowWriter::commit_raw() {
  // Blocks still waiting for cells, then blocks no window reached, as GDAL would fill them at
  // close (nodata, or 0 without one).
  for (auto& [index, p] : m_pending) {
    const std::vector<uint8_t> bytes = encode_float_block(p.cells.data());
    write_block(index, bytes.data(), bytes.size());
  }
  m_pending.clear();
  std::vector<float> block(size_t(kBlock) * kBlock);
  for (uint32_t index = 0; index < m_block_written.size(); ++index) {
    if (m_block_written[index]) continue;
    std::fill(block.begin(), block.end(), m_nodata ? float(*m_nodata) : 0.0f);
    const std::vector<uint8_t> bytes = encode_float_block(block.data());
    write_block(index, bytes.data(), bytes.size());
  }
  CPLErrorReset();
  TIFF* t = m_tif;
  m_tif = nullptr;
  const bool flushed = TIFFFlush(t) == 1;
  TIFFClose(t);
  if (!flushed || CPLGetLastErrorType() >= CE_Failure) {
    discard_temporary(m_tmp);
    fail("io", "finishing GeoTIFF {} failed ({})", m_path, name_output(last_gdal_error(), m_tmp));
  }
  // What is known only now goes through GDAL: as write_geotiff, NaN cells without a nodata value
  // of the source get NaN as nodata; metadata items added after the first window.
  if ((!m_nodata && m_any_nan) || !m_late_metadata.empty()) {
    auto* ds = static_cast<GDALDataset*>(
        GDALOpenEx(m_tmp.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE, nullptr, nullptr, nullptr));
    if (ds) {
      if (!m_nodata && m_any_nan) ds->GetRasterBand(1)->SetNoDataValue(double(NAN));
      for (const auto& [k, v] : m_late_metadata) ds->SetMetadataItem(k.c_str(), v.c_str());
      GDALClose(ds);
    }
    if (!ds || CPLGetLastErrorType() >= CE_Failure) {
      discard_temporary(m_tmp);
      fail("io", "finishing GeoTIFF {} failed ({})", m_path, name_output(last_gdal_error(), m_tmp));
    }
  }
  commit_temporary(m_tmp, m_path);
}

}  // namespace terracl::io
