// SPDX-License-Identifier: Apache-2.0
#pragma once
// Window-by-window raster I/O through GDAL, for tiled (out-of-core) runs: a reader that reads any
// window of a GDAL raster (a VRT mosaic included) and a writer that fills a tiled GeoTIFF window by
// window. Neither holds more than the window it is given (plus GDAL's block cache).
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <terracl/heightfield.hpp>
#include <vector>

class GDALDataset;
struct tiff;

namespace terracl::io {
/// FNV-1a 64 of `n` float32 cells' bytes: the checksum of a window in a resume journal.
uint64_t window_checksum(const float* cells, size_t n);
}  // namespace terracl::io

namespace terracl::io {

class GdalWindowReader {
 public:
  explicit GdalWindowReader(const std::string& path);
  ~GdalWindowReader();
  GdalWindowReader(const GdalWindowReader&) = delete;
  GdalWindowReader& operator=(const GdalWindowReader&) = delete;
  int width() const { return m_header.width; }
  int height() const { return m_header.height; }
  /// Georef and metadata of the whole raster (z is empty).
  const Heightfield& header() const { return m_header; }
  /// Cells [x, x + w) x [y, y + h), nodata as NaN; the georef is the whole raster's (same metric
  /// cell size, so that stages compute what they would untiled) with the geotransform moved to
  /// the window's corner.
  Heightfield read(int x, int y, int w, int h, int band = 1) const;
  int bands() const;
  /// The description GDAL holds for a band (a gradient's "gx" / "gy").
  std::string band_description(int band) const;
  /// Drops the blocks GDAL has cached for this raster (a reader that moves on for good, such as
  /// the streamed render, keeps its memory to the window it holds instead of GDAL's cache size).
  void release_cache() const;

 private:
  std::string m_path;
  GDALDataset* m_ds = nullptr;
  Heightfield m_header;
};

/// The DEFLATE level of every GeoTIFF terracl writes unless --co ZLEVEL says otherwise: level 1
/// (libdeflate's fastest) compresses float rasters with the floating-point predictor to within ~2 %
/// of the default level 6's size in half the CPU time (an 8193^2 slope raster: 174 against 171 MB,
/// 3.7 against 7.2 s; docs/io.md).
constexpr int kDeflateLevel = 1;

/// One 256^2 block of float32 cells (row-major, padding included) compressed as GDAL's GTiff
/// driver compresses it through libtiff (floating-point predictor + DEFLATE at kDeflateLevel): the bytes TIFFReadRawTile returns from GDAL's file (test: GeoTiffRaw*).
std::vector<uint8_t> encode_float_block(const float* cells);

/// GeoTiffWindowWriter::metres_per_unit() of a writer made with this georef and metadata.
double written_metres_per_unit(const Georef& georef, const Metadata& metadata);

/// A float32 GeoTIFF (tiled, DEFLATE + floating-point predictor, BigTIFF when it may pass 4 GB)
/// written window by window under a temporary name; finish() closes it, commit() renames it.
/// GDAL creates the file (georef, nodata, metadata), libtiff appends the blocks compressed by
/// encode() (TIFFWriteRawTile): encode() needs no file, so under MPI the rank that computed a
/// window compresses it and rank 0 only appends (put()); the file does not depend on who encoded.
/// Blocks that a window covers only in part wait in memory for their other cells (rank 0
/// compresses those). A resumable writer (`partial`) writes through GDAL as before.
class GeoTiffWindowWriter {
 public:
  /// `georef` and `metadata` are the whole raster's (as write_geotiff would store them).
  /// `partial` (resumable runs, --resume): a fixed temporary name instead of a unique one; it is
  /// kept when the writer is destroyed uncommitted, and an existing float32 GeoTIFF of this size
  /// there is reopened for update (reopened()) rather than recreated.
  /// `bands` = 2: a gradient field (band 1 gx, band 2 gy, described so; gradient_tiff.cpp).
  /// `compress` = false: uncompressed blocks, written through GDAL (windows from encode(...,
  /// false), cells only).
  GeoTiffWindowWriter(const std::string& path, int width, int height, const Georef& georef, const Metadata& metadata,
                      const std::string& partial = {}, int bands = 1, bool compress = true);
  ~GeoTiffWindowWriter();  ///< discards the temporary file unless committed (or resumable)
  GeoTiffWindowWriter(const GeoTiffWindowWriter&) = delete;
  GeoTiffWindowWriter& operator=(const GeoTiffWindowWriter&) = delete;
  /// Writes cells [sx, sx + w) x [sy, sy + h) of `src` at (x, y) of the output; returns the
  /// checksum (window_checksum) of the float32 cells as stored (nodata substituted).
  uint64_t write(int x, int y, const Heightfield& src, int sx, int sy, int w, int h, int band = 1);
  /// write() in two halves. encode(): the window's cells with nodata substituted, its blocks that
  /// lie wholly inside it compressed (compress = false: cells only, for a resumable writer), for a
  /// width x height raster whose nodata is `nodata`; any process may call it.
  /// `metres_per_unit`: the cells are metres written in another unit (value / metres_per_unit):
  /// the writer's metres_per_unit(), which any process can compute as written_metres_per_unit().
  static std::vector<uint8_t> encode(int width, int height, std::optional<double> nodata, int x, int y,
                                     const Heightfield& src, int sx, int sy, int w, int h, bool compress = true,
                                     double metres_per_unit = 1.0);
  /// Metres per unit of the band as written: 1, or the unit the data was read in (feet, ...; see
  /// io::written_vertical_unit) for lengths in metres read from such a band.
  double metres_per_unit() const { return m_metres_per_unit; }
  /// put(): stores what encode() made for this writer's raster; returns write()'s checksum.
  uint64_t put(const std::vector<uint8_t>& encoded, int band = 1);
  /// Whether this writer takes compressed blocks (encode(..., compress)): not when resumable, nor
  /// for two bands (GDAL interleaves them by band; the raw path knows one).
  bool compresses() const { return !m_resumable && m_bands == 1 && m_compress; }
  /// The checksum of the stored cells [x, x + w) x [y, y + h), read back from the file.
  uint64_t checksum(int x, int y, int w, int h, int band = 1);
  int bands() const { return m_bands; }
  /// Writes GDAL's dirty blocks and the TIFF directory to the file, so that a process killed
  /// afterwards leaves a readable file holding every window written so far.
  void flush();
  bool reopened() const { return m_reopened; }
  /// One more metadata item (terracl:x is stored as terracl_x, as in the constructor), for what is
  /// only known once every window is written (resize's engine scale).
  void set_metadata_item(const std::string& key, const std::string& value);
  /// Closes the file and renames it to its final name.
  void commit();
  const std::string& path() const { return m_path; }

 private:
  struct Pending {  // a block that windows have filled in part
    std::vector<float> cells;
    size_t filled = 0;
  };
  void write_block(uint32_t index, const uint8_t* bytes, size_t n);
  void commit_raw();
  void commit_compacted();  // resumable outputs
  size_t block_cells(uint32_t index) const;  // its cells inside the raster
  std::string m_path, m_tmp;
  int m_width = 0, m_height = 0, m_blocks_x = 0, m_blocks_y = 0, m_bands = 1;
  GDALDataset* m_ds = nullptr;  // resumable: GDAL writes
  tiff* m_tif = nullptr;        // otherwise: libtiff appends encoded blocks
  std::map<uint32_t, Pending> m_pending;
  std::vector<char> m_block_written;
  std::vector<std::pair<std::string, std::string>> m_late_metadata;  // set_metadata_item, applied by commit()
  bool m_resumable = false, m_reopened = false, m_compress = true;
  std::optional<double> m_nodata;
  double m_metres_per_unit = 1.0;
  bool m_any_nan = false;
  std::vector<float> m_buffer;
};

}  // namespace terracl::io
