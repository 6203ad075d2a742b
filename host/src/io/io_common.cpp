#include "io/io_common.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace terracl {
namespace fs = std::filesystem;

namespace io {

std::string sniff_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[8] = {0};
  in.read(reinterpret_cast<char*>(b), 8);
  const auto n = in.gcount();
  if (n >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "PNG";
  if (n >= 4 && ((b[0] == 'I' && b[1] == 'I' && (b[2] == 42 || b[2] == 43) && b[3] == 0) ||
                 (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && (b[3] == 42 || b[3] == 43))))
    return "TIFF";
  if (n >= 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01) return "EXR";
  if (n >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) return "JPEG";
  return "";
}

void require_readable(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail("io", "{}: no such file", path);
  if (fs::is_directory(path, ec)) fail("io", "{}: is a folder, expected a raster file", path);
  if (fs::file_size(path, ec) == 0) fail("io", "{}: file is empty", path);
  if (::access(path.c_str(), R_OK) != 0) fail("io", "{}: not readable ({})", path, std::strerror(errno));
}

void require_writable_folder(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail("io", "cannot write {}: folder {} does not exist", path, dir.string());
  if (::access(dir.c_str(), W_OK) != 0) fail("io", "cannot write {}: folder {} is not writable", path, dir.string());
}

std::string sidecar_path(const std::string& path) { return path + ".json"; }

nlohmann::json read_sidecar(const std::string& path) {
  const std::string sc = sidecar_path(path);
  std::ifstream in(sc);
  if (!in) return nullptr;
  try {
    nlohmann::json j = nlohmann::json::parse(in);
    if (!j.is_object()) fail("io", "{}: sidecar must be a JSON object", sc);
    return j;
  } catch (const nlohmann::json::exception& e) {
    fail("io", "{}: malformed sidecar JSON: {}", sc, e.what());
  }
}

nlohmann::json georef_to_json(const Georef& g) {
  nlohmann::json j;
  j["cell_x"] = g.cell_x;
  j["cell_y"] = g.cell_y;
  j["vertical_units"] = g.vertical_units;
  if (g.has_geotransform) j["geotransform"] = g.geotransform;
  if (!g.crs_wkt.empty()) j["crs_wkt"] = g.crs_wkt;
  j["geographic"] = g.geographic;
  if (g.nodata) j["nodata"] = *g.nodata;
  return j;
}

void georef_from_json(const nlohmann::json& j, Georef& g, const std::string& where) {
  try {
    if (j.contains("geotransform")) {
      g.geotransform = j.at("geotransform").get<std::array<double, 6>>();
      g.has_geotransform = true;
    }
    if (j.contains("crs_wkt")) g.crs_wkt = j.at("crs_wkt").get<std::string>();
    if (j.contains("geographic")) g.geographic = j.at("geographic").get<bool>();
    if (j.contains("vertical_units")) g.vertical_units = j.at("vertical_units").get<std::string>();
    if (j.contains("nodata") && j.at("nodata").is_number()) g.nodata = j.at("nodata").get<double>();
    if (j.contains("cell_x")) g.cell_x = j.at("cell_x").get<double>();
    if (j.contains("cell_y")) g.cell_y = j.at("cell_y").get<double>();
  } catch (const nlohmann::json::exception& e) {
    fail("io", "{}: bad georeferencing field: {}", where, e.what());
  }
  if (!(g.cell_x > 0) || !(g.cell_y > 0) || !std::isfinite(g.cell_x) || !std::isfinite(g.cell_y))
    fail("io", "{}: cell_x/cell_y must be positive numbers", where);
}

std::pair<double, double> finite_range(const std::vector<float>& z) {
  double lo = INFINITY, hi = -INFINITY;
  for (float v : z)
    if (std::isfinite(v)) lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
  if (lo > hi) return {0.0, 0.0};
  return {lo, hi};
}

}  // namespace io

std::string temporary_path_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  // Keep the extension last so that libraries choosing the format by extension still work.
  const std::string name = fmt::format(".{}.tmp{}-{}{}", p.stem().string(), ::getpid(), counter++, p.extension().string());
  return (p.parent_path() / name).string();
}

void commit_temporary(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    fail("io", "cannot move the finished output into place at {}: {}", path, ec.message());
  }
}

void discard_temporary(const std::string& tmp) {
  std::error_code ec;
  fs::remove(tmp, ec);
}

void write_text_file_atomic(const std::string& path, const std::string& content) {
  io::require_writable_folder(path);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << content;
    out.close();
    if (!out) fail("io", "cannot write {}", path);
  });
}

}  // namespace terracl
