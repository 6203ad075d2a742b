#pragma once
// Window-by-window raster I/O through GDAL, for tiled (out-of-core) runs: a reader that reads any
// window of a GDAL raster (a VRT mosaic included) and a writer that fills a tiled GeoTIFF window by
// window. Neither holds more than the window it is given (plus GDAL's block cache).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <terracl/heightfield.hpp>
#include <vector>

class GDALDataset;

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

/// A float32 GeoTIFF (tiled, DEFLATE + floating-point predictor, BigTIFF when it may pass 4 GB)
/// written window by window under a temporary name; finish() closes it, commit() renames it.
class GeoTiffWindowWriter {
 public:
  /// `georef` and `metadata` are the whole raster's (as write_geotiff would store them).
  /// `partial` (resumable runs, --resume): a fixed temporary name instead of a unique one; it is
  /// kept when the writer is destroyed uncommitted, and an existing float32 GeoTIFF of this size
  /// there is reopened for update (reopened()) rather than recreated.
  /// `bands` = 2: a gradient field (band 1 gx, band 2 gy, described so; gradient_tiff.cpp).
  GeoTiffWindowWriter(const std::string& path, int width, int height, const Georef& georef, const Metadata& metadata,
                      const std::string& partial = {}, int bands = 1);
  ~GeoTiffWindowWriter();  ///< discards the temporary file unless committed (or resumable)
  GeoTiffWindowWriter(const GeoTiffWindowWriter&) = delete;
  GeoTiffWindowWriter& operator=(const GeoTiffWindowWriter&) = delete;
  /// Writes cells [sx, sx + w) x [sy, sy + h) of `src` at (x, y) of the output; returns the
  /// checksum (window_checksum) of the float32 cells as stored (nodata substituted).
  uint64_t write(int x, int y, const Heightfield& src, int sx, int sy, int w, int h, int band = 1);
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
  std::string m_path, m_tmp;
  GDALDataset* m_ds = nullptr;
  int m_bands = 1;
  bool m_resumable = false, m_reopened = false;
  std::optional<double> m_nodata;
  bool m_any_nan = false;
  std::vector<float> m_buffer;
};

}  // namespace terracl::io
