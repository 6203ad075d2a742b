// SPDX-License-Identifier: Apache-2.0
#pragma once
// Shared helpers of the I/O backends (private to host/src/io).
#include <terracl/heightfield.hpp>
#include <terracl/io.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>

class GDALDataset;
class GDALRasterBand;

namespace terracl::io {

/// Drops the terracl:* items a file was read with (they tell how *that* file was made; outputs get
/// their own provenance), but keeps what describes the data itself: the unit elevations were read
/// in (terracl:source_vertical_units, written back by the GDAL writers).
inline void drop_terracl_keys(Metadata& md) {
  for (auto it = md.begin(); it != md.end();)
    it = it->first.rfind("terracl:", 0) == 0 && it->first != "terracl:source_vertical_units" ? md.erase(it)
                                                                                            : std::next(it);
}

/// What the file's first bytes say it is ("PNG", "TIFF", "EXR", "" when unknown or empty).
std::string sniff_magic(const std::string& path);
/// Throws when an EXR file's header claims an attribute larger than the file: OpenEXR allocates
/// what the header says (a fuzzed 1.5 KB file took 1.8 GB and 6 s) before noticing.
void check_exr_header(const std::string& path);
/// Rows [y0, y1) of a two-channel gradient EXR (y0 == y1: the header only), every check of
/// read_gradient applied; `full_height` receives the file's row count.
GradientField read_gradient_rows(const std::string& path, int y0, int y1, int* full_height = nullptr);
/// Refuses a PNG whose chunk lengths run past the end of the file, before libpng allocates them.
void check_png_chunks(const std::string& path);
/// Throws "io: <path>: ..." when the file is missing, unreadable, empty or a folder.
void require_readable(const std::string& path);
/// Throws when the folder of `path` is missing or not writable.
void require_writable_folder(const std::string& path);

std::string sidecar_path(const std::string& path);  // "<file>.json"
/// Sidecar JSON if present (null otherwise); a malformed one is an error naming the file.
nlohmann::json read_sidecar(const std::string& path);
nlohmann::json georef_to_json(const Georef& g);
void georef_from_json(const nlohmann::json& j, Georef& g, const std::string& where);

/// Throws naming `path` and the cell when `h` holds +-Inf (NaN is nodata; Inf is no elevation).
void check_finite_or_nodata(const Heightfield& h, const std::string& path, const char* verb);

/// Throws naming `where` unless zmin and zmax are finite and zmin <= zmax (a swapped range would
/// turn the terrain upside down without a word).
void check_vertical_range(double zmin, double zmax, const std::string& where);
/// Throws "io: <path>: <source> gives a cell size ...; expected ... within [min_cell_size, max_cell_size] m"
/// unless both cell sizes are; `source` names where they came from (the geotransform, a sidecar...).
void check_cell_size(const Georef& g, const std::string& path, const std::string& source);
/// Where a raster read by read_heightfield got its cell size, for check_cell_size's message.
std::string cell_size_source(const Georef& g, const std::string& path, bool from_option);

/// Throws when the sidecar `sc` of `path` states a width/height other than the image's.
void check_sidecar_size(const nlohmann::json& sc, const std::string& path, long long width, long long height);
/// Throws naming both files when the sidecar records an image size and FNV-1a ("image_bytes",
/// "image_fnv1a64") that `path` does not have: the pair was not written together.
void check_sidecar_image(const nlohmann::json& sc, const std::string& path);

/// Min/max of the finite values; {0, 0} when none are finite.
std::pair<double, double> finite_range(const std::vector<float>& z);

/// The 16-bit code <-> metres mapping of PNG16/RAW16. Code 0 is reserved for nodata when the
/// raster has nodata (sidecar "nodata_code": 0): the data then use codes 1..65535, so the top of
/// the range keeps 65535 as engines expect, and nodata reads back as NaN rather than as zmin.
struct Quantiser {
  double zmin = 0.0, zmax = 65535.0, max_code = 65535.0;
  bool reserve_nodata = false;  ///< code 0 is nodata
  uint16_t encode(float v) const;
  float decode(unsigned code) const;
};
/// The code that marks nodata in PNG16/RAW16 files terracl writes.
constexpr unsigned kNodataCode = 0;
/// Applies a sidecar's "nodata_code" to `q` (only 0 is accepted: it is the code terracl writes).
void quantiser_from_sidecar(const nlohmann::json& sc, Quantiser& q, const std::string& sidecar);
/// Reports a 16-bit raster read without a sidecar and without --zmin/--zmax/--cell-size.
void warn_sidecarless(const std::string& path, const char* kind);

Heightfield read_gdal(const std::string& path);
/// Throws "io: <path>: ..." when a GeoTIFF's block size is out of all proportion to the raster or
/// a block's offset + byte count lies past the end of the file, before GDAL allocates or reads it.
void check_tiff_blocks(GDALDataset& ds, const std::string& path);
/// Throws unless band 1 of `ds` is the whole elevation: a 3-band or complex-valued raster was read
/// as its first band (or real part) without a word.
void check_single_band(GDALDataset& ds, const std::string& path);
/// A two-band gx/gy gradient GeoTIFF (gradient_tiff.cpp), which window readers read band by band.
bool is_gradient_tiff(GDALDataset& ds);
/// Width and height from a raster's header, pixels unread (GDAL); nullopt when it is not a
/// raster GDAL opens (the core build: always), so that a size check is skipped, not failed.
std::optional<std::pair<int64_t, int64_t>> raster_header_size(const std::string& path);
/// Georef (metric cell size of the whole raster) and terracl metadata of an open dataset; sets
/// georef.nodata but converts no value (convert_nodata does, on what was read).
void read_gdal_header(GDALDataset& ds, Heightfield& out);
/// Cells equal to georef.nodata become NaN.
void convert_nodata(Heightfield& h);
/// After convert_nodata: the band's scale/offset (GDAL: value = raw * scale + offset) and a vertical
/// unit in feet, US survey feet, cm, mm or dm applied to the cells, so that they are metres.
void apply_band_scaling(GDALRasterBand& band, Heightfield& h);
/// The geotransform of `g`, or for a raster without one the local metric grid (origin 0, cells of
/// cell_x by cell_y metres, north up) that read_gdal_header recognises as "not georeferenced".
void set_geotransform_for_writing(GDALDataset& ds, const Georef& g, int height);
/// The GDAL driver that writes `path`: `asked` (an -of name) when given, else the one driver whose
/// extensions include the path's; throws naming the path when none or several do.
std::string gdal_driver_for_output(const std::string& path, const std::string& asked);
/// Writes `h` with GDAL's `driver` (CreateCopy) at tmp_path; returns every file the dataset is
/// made of (tmp_path first or among them: a .prj, a .hdr, an .aux.xml).
std::vector<std::string> write_gdal_copy(const Heightfield& h, const std::string& tmp_path, const std::string& driver,
                                         const WriteOptions& opts);
void write_geotiff(const Heightfield& h, const std::string& tmp_path, const WriteOptions& opts = {});

Heightfield read_image(const std::string& path, const ReadOptions& opts);
void write_png16(const Heightfield& h, const std::string& tmp_path, double zmin, double zmax);
void write_exr(const Heightfield& h, const std::string& tmp_path);

Heightfield read_raw16(const std::string& path, const ReadOptions& opts);
void write_raw16(const Heightfield& h, const std::string& tmp_path, double zmin, double zmax);

/// NumPy .npy (io/npy.cpp): 2-D, C order, little-endian float32/float64/int16/uint16 in; float32 out.
Heightfield read_npy(const std::string& path, const ReadOptions& opts);
void write_npy(const Heightfield& h, const std::string& tmp_path);

}  // namespace terracl::io
