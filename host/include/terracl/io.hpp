// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Reading and writing heightfields and gradient fields. The format comes from the file's
/// extension and is checked against the file's content:
///   .tif/.tiff (GDAL, GeoTIFF), .hgt (SRTM), .asc (ESRI ASCII grid), other GDAL rasters on read;
///   .png (8/16-bit), .exr (float) through libpng/OpenEXR; .r16/.raw (RAW16 little-endian);
///   .npy (NumPy 2-D array: reads float32/float64/int16/uint16, writes float32).
/// Writers put the output under a temporary name in the same folder and rename it when complete,
/// so a failure never leaves a partial file.
#include <terracl/heightfield.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace terracl {

/// Cell sizes every reader and writer accepts, in metres: a micrometre (lab scans) to 1000 km (a
/// global grid of ten-degree cells). Outside them slopes, areas and mesh coordinates overflow to
/// Inf or NaN. Elevations are finite numbers, or NaN for nodata (+-Inf is refused).
constexpr double min_cell_size = 1e-6, max_cell_size = 1e6;

/// What the file cannot say itself (sizes and ranges of RAW16/PNG), and nodata filling.
struct ReadOptions {
  /// Vertical range that 0 and the largest code of a PNG/RAW16 map to (overrides the sidecar).
  std::optional<double> zmin, zmax;
  /// Size of a RAW16 file (overrides the sidecar).
  std::optional<int> width, height;
  /// Cell size in metres for formats without georeferencing (overrides the sidecar).
  std::optional<double> cell_size;
  /// Harmonic fill of nodata cells after reading.
  bool fill_nodata = false;
};

struct WriteOptions {
  /// Vertical range mapped to 0..65535 in PNG16/RAW16 (default: the data's min/max). With nodata,
  /// code 0 is reserved for it and the range maps to 1..65535 (sidecar "nodata_code": 0).
  std::optional<double> zmin, zmax;
  /// GeoTIFF only: GDAL creation options KEY=VALUE (gdal_translate's -co), added to and
  /// overriding terracl's defaults (COMPRESS=DEFLATE, PREDICTOR, TILED).
  std::vector<std::string> creation_options;
  /// GeoTIFF only: write a Cloud Optimized GeoTIFF (GDAL's COG driver) instead of a plain GTiff.
  bool cog = false;
  /// GeoTIFF only: band type, Float32 (default), Float64, Int16, UInt16 or Int32 (values are
  /// rounded; NaN cells get the nodata value, -32768 / 65535 / -2147483648 when there is none).
  std::string output_type = "Float32";
  /// A GDAL raster driver by name (gdal_translate's -of: "AAIGrid", "HFA", "GPKG", ...) for an
  /// output terracl does not write itself; empty: from the extension (.tif .exr .png .r16 .npy are
  /// terracl's, any other extension goes to the one GDAL driver that claims it).
  std::string driver;
};

/// Non-fatal I/O warnings (a 16-bit PNG read without its sidecar) go to this handler; by default
/// they print "terracl: warning: ..." on stderr. Pass an empty function to restore the default.
void set_warning_handler(std::function<void(const std::string&)> handler);
void warn(const std::string& message);

enum class FileFormat { GeoTIFF, HGT, AsciiGrid, PNG, EXR, TIFF, RAW16, GDALOther, NPY, Unknown };
/// Format from the extension (lower-cased); Unknown when not recognised.
FileFormat format_from_extension(const std::string& path);
/// "GeoTIFF", "PNG", ... for messages.
const char* format_name(FileFormat f);

/// Reads elevations in metres (nodata cells NaN, georeferencing kept); errors name the file.
Heightfield read_heightfield(const std::string& path, const ReadOptions& opts = {});
/// Writes in the format of the extension, with georeferencing and provenance, atomically.
void write_heightfield(const Heightfield& h, const std::string& path, const WriteOptions& opts = {});

/// Gradient fields travel as two-channel float EXR ("gx", "gy"), with the cell size, georef and
/// mean elevation as attributes.
GradientField read_gradient(const std::string& path);
void write_gradient(const GradientField& g, const std::string& path);

/// True when the file is an EXR with two channels named gx/gy (or any two channels).
bool is_gradient_file(const std::string& path);

/// A file named on the command line or in a pipeline, with the flag or JSON path that named it.
struct NamedPath {
  std::string label;  ///< "-o", "--delta", "/2/file"
  std::string path;
};
/// Throws UsageError(stage, ...) when a component of `path` is longer than the file system allows
/// (255 bytes) or the whole path longer than 4095 bytes (a 5,000-character name).
void check_path_length(const std::string& stage, const std::string& label, const std::string& path);
/// True when `a` and `b` name the same file: the same inode when both exist, else the same
/// canonical path ("out/a.tif" and "./out/../out/a.tif").
bool same_file(const std::string& a, const std::string& b);

/// Whether `path` names something that exists (a regular file when `regular`). Never throws:
/// std::filesystem::exists throws on a name too long or a loop of links, which for a user's
/// path means "not there" (the caller's own not-found message then names the field).
bool path_exists(const std::string& path, bool regular = false) noexcept;
/// Whether `path` is one of GDAL's virtual file systems (/vsizip/, /vsicurl/, /vsis3/, /vsimem/,
/// ...). Such paths are opened by GDAL alone: there is no folder to check, and a missing file is
/// reported by GDAL's open. path_exists() answers true for them.
bool is_virtual_path(const std::string& path) noexcept;
/// The band type a GDAL raster stores when terracl would write it back unchanged (Int16, UInt16,
/// Int32, Float64: what `--ot` can name), so that convert/warp/resize keep the input's type as
/// gdal_translate and gdalwarp do; "" for Float32, other types, scaled bands, units converted on
/// read, and files GDAL does not read.
std::string stored_band_type(const std::string& path);
/// The one check every command and pipeline makes before running: refuses (UsageError naming the
/// labels) an output that is also an input or another output, and an output that exists and is
/// not a regular file (a device such as /dev/null, a folder, a pipe), which a rename would replace.
void check_output_paths(const std::string& stage, const std::vector<NamedPath>& inputs,
                        const std::vector<NamedPath>& outputs);

/// Writes `content` to `path` atomically (temporary name in the same folder, then rename).
void write_text_file_atomic(const std::string& path, const std::string& content);

/// Runs `writer(tmp_path)` and renames tmp_path to `path` on success; removes tmp_path on failure.
/// The temporary name keeps the extension so format-by-extension libraries still work.
template <typename F>
void write_atomically(const std::string& path, F&& writer);

/// The pieces of write_atomically for writers that cannot take a callback: a registered
/// temporary name beside `path`, its rename to `path`, or its removal.
std::string temporary_path_for(const std::string& path);
void commit_temporary(const std::string& tmp, const std::string& path);
void discard_temporary(const std::string& tmp);
/// Unlinks every temporary output not yet committed or discarded. Async-signal-safe (no
/// allocation, no locks): the CLI calls it from its SIGTERM / second-Ctrl-C handler.
void remove_temporaries_signal_safe();

template <typename F>
void write_atomically(const std::string& path, F&& writer) {
  const std::string tmp = temporary_path_for(path);
  try {
    writer(tmp);
  } catch (...) {
    discard_temporary(tmp);
    throw;
  }
  commit_temporary(tmp, path);
}

}  // namespace terracl
