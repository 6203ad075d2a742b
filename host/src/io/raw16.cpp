// SPDX-License-Identifier: Apache-2.0
// RAW16: headerless little-endian uint16 (Unreal/Unity heightmaps). Size and vertical range live
// in the JSON sidecar "<file>.json" or come from options; without a size the file is ambiguous.
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace terracl::io {

namespace {
// get<int>() wraps: a width of 1e20 was reported as -2147483648. Read the number as given, then bound it.
int sidecar_side(const nlohmann::json& sc, const char* key, const std::string& path) {
  const nlohmann::json& v = sc.at(key);
  const double d = v.is_number() ? v.get<double>() : NAN;
  if (!v.is_number() || d != std::floor(d) || d < 1 || d > double(max_raster_side))
    fail("io", "{}: {} is {}; expected a whole number of cells in [1, {}]", sidecar_path(path), key,
         abbreviate(v.dump(), 30), max_raster_side);
  return int(d);
}
}  // namespace

Heightfield read_raw16(const std::string& path, const ReadOptions& opts) {
  const nlohmann::json sc = read_sidecar(path);
  std::optional<int> w = opts.width, h = opts.height;
  double zmin = 0.0, zmax = 65535.0;
  Georef g;
  Metadata md;
  if (!sc.is_null()) {
    try {
      if (!w && sc.contains("width")) w = sidecar_side(sc, "width", path);
      if (!h && sc.contains("height")) h = sidecar_side(sc, "height", path);
      if (sc.contains("zmin")) zmin = sc.at("zmin").get<double>();
      if (sc.contains("zmax")) zmax = sc.at("zmax").get<double>();
    } catch (const nlohmann::json::exception& e) {
      fail("io", "{}: sidecar fields width/height/zmin/zmax have the wrong type ({})", sidecar_path(path), e.what());
    }
    check_sidecar_image(sc, path);
    georef_from_json(sc, g, sidecar_path(path));
    if (sc.contains("metadata") && sc["metadata"].is_object())
      for (auto& [k, v] : sc["metadata"].items())
        if (v.is_string()) md[k] = v.get<std::string>();
  }
  if (!w || !h)
    fail("io", "{}: RAW16 needs its size: no sidecar {} with width/height, and no --width/--height given", path,
         sidecar_path(path));
  if (*w <= 0 || *h <= 0) fail("io", "{}: RAW16 size must be positive, got {} x {}", path, *w, *h);
  if (opts.zmin) zmin = *opts.zmin;
  if (opts.zmax) zmax = *opts.zmax;
  check_vertical_range(zmin, zmax, sc.is_null() ? path : sidecar_path(path));
  const uint64_t expected = uint64_t(*w) * uint64_t(*h) * 2;
  const uint64_t actual = std::filesystem::file_size(path);
  if (actual != expected)
    fail("io", "{}: RAW16 of {} x {} must be {} bytes, the file has {}", path, *w, *h, expected, actual);
  require_raster_size("io", path, *w, *h, 6);
  std::ifstream in(path, std::ios::binary);
  std::vector<unsigned char> bytes(expected);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(expected));
  if (!in) fail("io", "{}: read failed", path);
  Heightfield out(*w, *h);
  if (sc.is_null() && !opts.zmin && !opts.zmax && !opts.cell_size) warn_sidecarless(path, "RAW16");
  Quantiser q{zmin, zmax, 65535.0};
  quantiser_from_sidecar(sc, q, sidecar_path(path));
  for (size_t i = 0; i < out.size(); ++i) out.z[i] = q.decode(unsigned(bytes[2 * i]) | (unsigned(bytes[2 * i + 1]) << 8));
  if (q.reserve_nodata && !g.nodata) g.nodata = double(NAN);
  out.georef = g;
  out.metadata = md;
  if (opts.cell_size) out.georef.cell_x = out.georef.cell_y = *opts.cell_size;
  return out;
}

void write_raw16(const Heightfield& h, const std::string& tmp_path, double zmin, double zmax) {
  std::vector<unsigned char> bytes(h.size() * 2);
  const Quantiser q{zmin, zmax, 65535.0, h.count_nodata() > 0};
  for (size_t i = 0; i < h.size(); ++i) {
    const unsigned code = q.encode(h.z[i]);
    bytes[2 * i] = static_cast<unsigned char>(code & 0xff);
    bytes[2 * i + 1] = static_cast<unsigned char>(code >> 8);
  }
  write_file_checked(tmp_path, bytes.data(), bytes.size());
}

}  // namespace terracl::io
