// SPDX-License-Identifier: Apache-2.0
// Format dispatch: the extension names the format and the content must agree, so that a PNG
// renamed .tif is refused with a clear message rather than silently read by whichever library
// recognises it.
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/warp.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace terracl {
namespace fs = std::filesystem;

FileFormat format_from_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".tif" || ext == ".tiff") return FileFormat::GeoTIFF;
  if (ext == ".hgt") return FileFormat::HGT;
  if (ext == ".asc") return FileFormat::AsciiGrid;
  if (ext == ".png") return FileFormat::PNG;
  if (ext == ".exr") return FileFormat::EXR;
  if (ext == ".r16" || ext == ".raw") return FileFormat::RAW16;
  if (ext == ".npy") return FileFormat::NPY;
  if (ext == ".img" || ext == ".vrt" || ext == ".dem" || ext == ".bil" || ext == ".nc" || ext == ".dt0" ||
      ext == ".dt1" || ext == ".dt2" || ext == ".xyz")
    return FileFormat::GDALOther;
  return FileFormat::Unknown;
}

const char* format_name(FileFormat f) {
  switch (f) {
    case FileFormat::GeoTIFF: return "GeoTIFF";
    case FileFormat::HGT: return "SRTM HGT";
    case FileFormat::AsciiGrid: return "ESRI ASCII grid";
    case FileFormat::PNG: return "PNG";
    case FileFormat::EXR: return "OpenEXR";
    case FileFormat::TIFF: return "TIFF";
    case FileFormat::RAW16: return "RAW16";
    case FileFormat::GDALOther: return "GDAL raster";
    case FileFormat::NPY: return "NumPy .npy";
    default: return "unknown";
  }
}

namespace {

const char* kKnown = ".tif .tiff .hgt .asc .png .exr .r16 .raw .npy (and other GDAL rasters: .img .vrt .dem .bil .nc .dt0-2 .xyz)";

void require_magic(const std::string& path, const char* expected, FileFormat f) {
  const std::string got = io::sniff_magic(path);
  if (got != expected)
    fail("io", "{}: extension says {} but the content is {}", path, format_name(f),
         got.empty() ? "not a " + std::string(format_name(f)) + " file" : "a " + got + " file");
}

void check_hgt(const std::string& path) {
  const auto size = fs::file_size(path);
  // SRTM3 (3") and SRTM1 (1") tiles; anything else is truncated or not an HGT.
  if (size != 1201ull * 1201 * 2 && size != 3601ull * 3601 * 2)
    fail("io", "{}: SRTM .hgt must be 2884802 bytes (SRTM3, 1201 x 1201) or 25934402 bytes (SRTM1, 3601 x 3601); "
         "this file has {} bytes (truncated?)", path, size);
}

void check_ascii_grid(const std::string& path) {
  std::ifstream in(path);
  std::string word;
  in >> word;
  std::transform(word.begin(), word.end(), word.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (word != "ncols" && word != "nrows")
    fail("io", "{}: an ESRI ASCII grid starts with an 'ncols' header line; found '{}'", path, word.substr(0, 40));
}

}  // namespace

Heightfield read_heightfield(const std::string& path, const ReadOptions& opts) {
  io::require_readable(path);
  // A GDAL virtual path (/vsizip/, /vsicurl/, ...) has no local bytes to sniff: GDAL reads it,
  // whatever its extension.
  const FileFormat f = is_virtual_path(path) && format_from_extension(path) != FileFormat::Unknown
                           ? FileFormat::GDALOther
                           : format_from_extension(path);
  Heightfield h;
  switch (f) {
    case FileFormat::GeoTIFF:
      require_magic(path, "TIFF", f);
      h = io::read_gdal(path);
      break;
    case FileFormat::HGT:
      check_hgt(path);
      h = io::read_gdal(path);
      break;
    case FileFormat::AsciiGrid:
      check_ascii_grid(path);
      h = io::read_gdal(path);
      break;
    case FileFormat::GDALOther:
      h = io::read_gdal(path);
      break;
    case FileFormat::PNG:
      require_magic(path, "PNG", f);
      h = io::read_image(path, opts);
      break;
    case FileFormat::EXR:
      require_magic(path, "EXR", f);
      h = io::read_image(path, opts);
      break;
    case FileFormat::RAW16:
      h = io::read_raw16(path, opts);
      break;
    case FileFormat::NPY:
      h = io::read_npy(path, opts);
      break;
    default:
      // Any other raster GDAL opens (.gpkg, .grd, .bt, ...), by its content.
      try {
        h = io::read_gdal(path);
      } catch (const Error&) {
        fail("io", "{}: unknown raster extension and not a raster GDAL opens; expected one of {}", path, kKnown);
      }
  }
  if (h.width <= 0 || h.height <= 0) fail("io", "{}: raster has no cells", path);
  if ((f == FileFormat::GeoTIFF || f == FileFormat::GDALOther) && !h.georef.has_geotransform) {
    // Our own non-georeferenced outputs keep their metric cell size as metadata.
    // strtod, not stod: a hostile tag is ignored rather than an "internal: stod".
    auto cell = [&](const char* key, double& v) {
      if (auto it = h.metadata.find(key); it != h.metadata.end()) {
        const double d = std::strtod(it->second.c_str(), nullptr);
        if (std::isfinite(d) && d > 0) v = d;
      }
    };
    cell("terracl:cell_x", h.georef.cell_x);
    cell("terracl:cell_y", h.georef.cell_y);
  }
  // Every reader ends here, so one check covers GeoTIFF, PNG, EXR, sidecar and option cell sizes: a NaN
  // cell size gave all-NaN drainage and mesh vertices, 1e300 overflowed to Inf.
  io::check_cell_size(h.georef, path,
                      io::cell_size_source(h.georef, path, opts.cell_size && h.georef.cell_x == *opts.cell_size));
  // NaN is nodata; +-Inf is no elevation at all and made invalid meshes (glb "max": null).
  io::check_finite_or_nodata(h, path, "holds");
  h.metadata.erase("terracl:cell_x");
  h.metadata.erase("terracl:cell_y");
  if (opts.fill_nodata) fill_nodata_harmonic(h);
  return h;
}

namespace {

// An image with a JSON sidecar is committed as one unit: both are written under temporary names,
// the sidecar records the image's size and FNV-1a so that a reader can tell a mismatched pair, then
// the image is renamed into place and the sidecar last. A failure before the image's rename leaves
// the earlier pair as it was; one between the two renames leaves a new image beside the old
// sidecar, which the reader refuses (check_sidecar_size) rather than decoding it with the wrong
// range (the sidecar used to be renamed first, so a failed image rename did exactly that).
// `gdal_view`: what GDAL reads the image through, as {suffix, content} (a 16-bit PNG's .aux.xml, a
// RAW16's ENVI .hdr), written as path + suffix; none when the content is empty.
template <typename F>
void write_with_sidecar(const std::string& path, nlohmann::json sc, F&& write_image,
                        const std::pair<std::string, std::string>& gdal_view = {}) {
  const std::string& aux_xml = gdal_view.second;
  const std::string sc_path = io::sidecar_path(path), aux_path = path + gdal_view.first;
  const std::string tmp = temporary_path_for(path), sc_tmp = temporary_path_for(sc_path);
  const std::string aux_tmp = aux_xml.empty() ? std::string() : temporary_path_for(aux_path);
  auto discard_companions = [&] {
    discard_temporary(sc_tmp);
    if (!aux_tmp.empty()) discard_temporary(aux_tmp);
  };
  try {
    write_image(tmp);
    const io::FileDigest d = io::file_digest(tmp);
    sc["image_bytes"] = d.bytes;
    sc["image_fnv1a64"] = io::hex64(d.fnv1a);
    io::write_file_checked(sc_tmp, sc.dump(2) + "\n");
    if (!aux_tmp.empty()) io::write_file_checked(aux_tmp, aux_xml);
  } catch (...) {
    discard_temporary(tmp);
    discard_companions();
    throw;
  }
  try {
    commit_temporary(tmp, path);
  } catch (...) {
    discard_companions();
    throw;
  }
  try {
    commit_temporary(sc_tmp, sc_path);
  } catch (...) {
    if (!aux_tmp.empty()) discard_temporary(aux_tmp);
    throw;
  }
  // GDAL's view last: terracl's own pair is already consistent when this rename fails.
  if (!aux_tmp.empty()) commit_temporary(aux_tmp, aux_path);
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// What GDAL is told about a 16-bit image: its geotransform (the local metric grid when the raster
// has none) and the code -> metres mapping (code 0 is nodata when the raster has nodata).
struct CodesView {
  std::array<double, 6> gt;
  double scale, offset;
};
CodesView gdal_view_of_codes(const Heightfield& h, const io::Quantiser& q) {
  const Georef& g = h.georef;
  CodesView v{{0.0, g.cell_x, 0.0, g.cell_y * h.height, 0.0, -g.cell_y}, 0.0, 0.0};
  if (g.has_geotransform) v.gt = g.geotransform;
  const double lo = q.reserve_nodata ? 1.0 : 0.0;
  v.scale = (q.zmax - q.zmin) / (q.max_code - lo);
  v.offset = q.zmin - lo * v.scale;
  return v;
}

// GDAL's auxiliary metadata (PAM) for a 16-bit PNG: its geotransform (the local metric grid when
// the raster has none), CRS, and the code -> metres mapping as band scale/offset with code 0 as
// nodata, so that GDAL, QGIS and rasterio read the PNG in metres where terracl's JSON sidecar is
// invisible to them.
std::string png_aux_xml(const Heightfield& h, const io::Quantiser& q) {
  const Georef& g = h.georef;
  const auto [gt, scale, offset] = gdal_view_of_codes(h, q);
  std::string x = "<PAMDataset>\n";
  if (!g.crs_wkt.empty()) x += "  <SRS dataAxisToSRSAxisMapping=\"" + std::string(g.geographic ? "2,1" : "1,2") + "\">" +
                               xml_escape(g.crs_wkt) + "</SRS>\n";
  x += fmt::format("  <GeoTransform>{:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}</GeoTransform>\n", gt[0], gt[1],
                   gt[2], gt[3], gt[4], gt[5]);
  x += "  <PAMRasterBand band=\"1\">\n";
  if (q.reserve_nodata) x += fmt::format("    <NoDataValue>{}</NoDataValue>\n", io::kNodataCode);
  x += "    <UnitType>" + xml_escape(g.vertical_units) + "</UnitType>\n";
  x += fmt::format("    <Offset>{:.17g}</Offset>\n    <Scale>{:.17g}</Scale>\n", offset, scale);
  x += "  </PAMRasterBand>\n</PAMDataset>\n";
  return x;
}

// An ENVI header for a RAW16 file (GDAL's ENVI driver opens `x.r16` through `x.r16.hdr`): its
// size, little-endian uint16 cells, the geotransform (the local metric grid when the raster has
// none), CRS, and the code -> metres mapping as band gain/offset (code 0 ignored when it is
// nodata), so GDAL, QGIS and rasterio read a headerless heightmap in metres, georeferenced.
std::string raw16_envi_header(const Heightfield& h, const io::Quantiser& q) {
  const Georef& g = h.georef;
  const auto [gt, scale, offset] = gdal_view_of_codes(h, q);
  std::string x = "ENVI\ndescription = {terracl RAW16 heightmap (little-endian uint16)}\n";
  x += fmt::format("samples = {}\nlines = {}\nbands = 1\nheader offset = 0\nfile type = ENVI Standard\n", h.width,
                   h.height);
  x += "data type = 12\ninterleave = bsq\nbyte order = 0\n";
  if (gt[2] == 0.0 && gt[4] == 0.0)  // ENVI's map info has no rotation terms
    x += fmt::format("map info = {{Arbitrary, 1, 1, {:.17g}, {:.17g}, {:.17g}, {:.17g}}}\n", gt[0], gt[3], gt[1], -gt[5]);
  if (!g.crs_wkt.empty()) {
    std::string wkt = g.crs_wkt;
    std::replace(wkt.begin(), wkt.end(), '\n', ' ');
    x += "coordinate system string = {" + wkt + "}\n";
  }
  x += fmt::format("data gain values = {{{:.17g}}}\ndata offset values = {{{:.17g}}}\n", scale, offset);
  if (q.reserve_nodata) x += fmt::format("data ignore value = {}\n", io::kNodataCode);
  x += "band names = {elevation (" + g.vertical_units + ")}\n";
  return x;
}

// A GDAL format of several files (.asc + .prj, .bil + .hdr): written under a temporary name, then
// every file renamed to the output's name, the main file last so that it never stands beside
// stale companions.
void write_gdal_files(const Heightfield& h, const std::string& path, const std::string& driver, const WriteOptions& opts) {
  const std::string tmp = temporary_path_for(path);
  std::vector<std::string> files;
  try {
    files = io::write_gdal_copy(h, tmp, driver, opts);
  } catch (...) {
    // GDAL's file list is only known after a successful write, so the companions it may have
    // written before failing (dem.prj beside dem.asc) are found by the temporary's unique stem.
    const fs::path tp(tmp);
    const std::string family = tp.stem().string() + ".";
    std::error_code ec;
    for (fs::directory_iterator it(tp.parent_path().empty() ? fs::path(".") : tp.parent_path(), ec), end; !ec && it != end;
         it.increment(ec))
      if (it->path().filename().string().rfind(family, 0) == 0) fs::remove(it->path(), ec);
    discard_temporary(tmp);
    throw;
  }
  const fs::path tp(tmp), pp(path);
  const std::string tmp_stem = (tp.parent_path() / tp.stem()).string(), stem = (pp.parent_path() / pp.stem()).string();
  // Every file of the temporary's family moves, listed by GDAL or not (a driver may leave out a
  // companion it wrote).
  {
    std::error_code ec;
    const std::string family = tp.stem().string() + ".";
    for (fs::directory_iterator it(tp.parent_path().empty() ? fs::path(".") : tp.parent_path(), ec), end;
         !ec && it != end; it.increment(ec)) {
      const std::string f = (tp.parent_path() / it->path().filename()).string();
      if (it->path().filename().string().rfind(family, 0) == 0 && std::find(files.begin(), files.end(), f) == files.end())
        files.push_back(f);
    }
  }
  // Not every driver checks the writes of its companions (AAIGrid's .prj, the .aux.xml GDAL adds):
  // on a full disk one comes out empty and the output silently loses its CRS or unit.
  for (const std::string& file : files) {
    std::error_code ec;
    if (fs::path(file) != tp && fs::exists(file, ec) && fs::file_size(file, ec) == 0 && !ec) {
      for (const std::string& other : files) fs::remove(other, ec);
      discard_temporary(tmp);
      fail("io", "writing {} as {} failed: its companion {} came out empty (disk full?)", path, driver,
           fs::path(stem + file.substr(std::min(file.size(), tmp_stem.size()))).filename().string());
    }
  }
  for (const std::string& file : files) {
    if (fs::path(file) == tp) continue;
    std::string target;
    if (file.rfind(tmp, 0) == 0) target = path + file.substr(tmp.size());  // dem.asc.aux.xml
    else if (file.rfind(tmp_stem, 0) == 0) target = stem + file.substr(tmp_stem.size());  // dem.prj
    else continue;  // not ours to move
    std::error_code ec;
    fs::rename(file, target, ec);
    if (ec) {
      for (const std::string& other : files) fs::remove(other, ec);
      discard_temporary(tmp);
      fail("io", "cannot move {} into place at {}", file, target);
    }
  }
  commit_temporary(tmp, path);
}

}  // namespace

void write_heightfield(const Heightfield& h, const std::string& path, const WriteOptions& opts) {
  const std::string& drv = opts.driver;
  const FileFormat f = drv == "GTiff" || drv == "COG" ? FileFormat::GeoTIFF : format_from_extension(path);
  // Any other extension, or a driver named with --of: GDAL's driver for it.
  const bool by_gdal = (!drv.empty() && drv != "GTiff" && drv != "COG") || f == FileFormat::Unknown ||
                       f == FileFormat::HGT || f == FileFormat::AsciiGrid || f == FileFormat::GDALOther;
  if (h.width <= 0 || h.height <= 0 || h.z.size() != size_t(h.width) * h.height)
    fail("io", "{}: refusing to write an empty or inconsistent heightfield ({} x {})", path, h.width, h.height);
  if (f != FileFormat::GeoTIFF && !by_gdal && (!opts.creation_options.empty() || opts.cog || opts.output_type != "Float32"))
    fail("io", "{}: creation options, COG and output types apply to GDAL outputs (.tif and other GDAL formats) only",
         path);
  if (by_gdal && opts.cog) fail("io", "{}: --cog writes a GeoTIFF (.tif)", path);
  WriteOptions tiff = opts;
  if (drv == "COG") tiff.cog = true;
  // The reader's rules, so that nothing terracl writes (from the CLI or Python) is refused on reading.
  // Bad data handed to a writer is the caller's (Python: ValueError), as bad options are.
  try {
    io::check_finite_or_nodata(h, path, "would hold");
    io::check_cell_size(h.georef, path, "the heightfield being written");
  } catch (const Error& e) {
    throw UsageError(e.stage(), std::string(e.what()).substr(e.stage().size() + 2));
  }
  const std::string driver = by_gdal ? io::gdal_driver_for_output(path, drv) : std::string();
  if (is_virtual_path(path)) {
    // No folder to rename in (an object store, an archive, memory): GDAL writes the final name.
    if (by_gdal) return (void)io::write_gdal_copy(h, path, driver, opts);
    if (f != FileFormat::GeoTIFF)
      fail("io", "{}: GDAL virtual paths (/vsi...) are written through GDAL: .tif or another GDAL format", path);
    return io::write_geotiff(h, path, tiff);
  }
  io::require_writable_folder(path);
  if (by_gdal) return write_gdal_files(h, path, driver, opts);
  if (f == FileFormat::GeoTIFF) return write_atomically(path, [&](const std::string& t) { io::write_geotiff(h, t, tiff); });
  if (f == FileFormat::EXR) return write_atomically(path, [&](const std::string& t) { io::write_exr(h, t); });
  if (f == FileFormat::NPY) {
    // float32 as it is (NaN = nodata); the sidecar keeps the cell size, georeferencing and metadata.
    nlohmann::json sc = io::georef_to_json(h.georef);
    sc["width"] = h.width;
    sc["height"] = h.height;
    sc["format"] = "npy-float32";
    sc["metadata"] = h.metadata;
    return write_with_sidecar(path, sc, [&](const std::string& tmp) { io::write_npy(h, tmp); });
  }

  // Quantised formats: the image and its sidecar are both written under temporary names and
  // moved into place together.
  auto [lo, hi] = io::finite_range(h.z);
  const double zmin = opts.zmin.value_or(lo), zmax = opts.zmax.value_or(hi);
  if (!(zmax >= zmin)) fail("io", "{}: vertical range zmax ({}) is below zmin ({})", path, zmax, zmin);
  nlohmann::json sc = io::georef_to_json(h.georef);
  sc["width"] = h.width;
  sc["height"] = h.height;
  sc["zmin"] = zmin;
  sc["zmax"] = zmax;
  sc["format"] = f == FileFormat::PNG ? "png16-linear" : "raw16-le";
  // Engine import scale for the range actually written (a resize's metadata assumed the data range).
  const bool has_nodata = h.count_nodata() > 0;
  // Nodata keeps code 0 (io_common.hpp, Quantiser); data then use codes 1..65535.
  if (has_nodata) sc["nodata_code"] = io::kNodataCode;
  const EngineScale es = engine_scale(zmin, zmax, has_nodata, h.georef.cell_x, h.georef.cell_y);
  nlohmann::json engine = nlohmann::json::object();
  for (const auto& [k, v] : engine_scale_entries(es)) engine[k] = v;
  if (std::fabs(h.georef.cell_x - h.georef.cell_y) > 1e-3 * h.georef.cell_x)
    engine["warning"] = square_cell_advice(h);
  sc["engine"] = engine;
  Metadata md = h.metadata;
  for (const auto& [k, v] : engine_scale_entries(es)) md.erase("engine:" + k);
  sc["metadata"] = md;
  io::Quantiser q;
  q.zmin = zmin;
  q.zmax = zmax;
  q.reserve_nodata = has_nodata;
  write_with_sidecar(
      path, sc,
      [&](const std::string& tmp) {
        if (f == FileFormat::PNG)
          io::write_png16(h, tmp, zmin, zmax);
        else
          io::write_raw16(h, tmp, zmin, zmax);
      },
      f == FileFormat::PNG ? std::pair<std::string, std::string>{".aux.xml", png_aux_xml(h, q)}
                           : std::pair<std::string, std::string>{".hdr", raw16_envi_header(h, q)});
}

}  // namespace terracl
