// SPDX-License-Identifier: Apache-2.0
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <map>

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

void check_png_chunks(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const auto file_size = fs::file_size(path, ec);
  if (!in || ec) return;  // the reader reports it
  // libpng allocates a chunk's declared length before reading it: a 763-byte PNG whose tEXt chunk
  // claimed ~2 GB took 2 GB and 8 s to fail (fuzz_raster). Chunks: uint32 BE length, 4-byte type,
  // data, CRC; IEND ends the stream.
  in.seekg(8);
  for (int chunk = 0; chunk < 100000; ++chunk) {
    unsigned char b[8];
    if (!in.read(reinterpret_cast<char*>(b), 8)) return;  // truncated: the reader reports it
    const uint64_t length = uint64_t(b[0]) << 24 | uint64_t(b[1]) << 16 | uint64_t(b[2]) << 8 | uint64_t(b[3]);
    std::string type(reinterpret_cast<const char*>(b + 4), 4);
    for (char& c : type)
      if (!std::isalpha(static_cast<unsigned char>(c))) c = '?';  // a damaged type is not text
    const uint64_t left = uint64_t(file_size) - uint64_t(in.tellg());
    if (length + 4 > left)
      fail("io", "{}: PNG chunk '{}' claims {} bytes, and {} bytes are left in the file; the file is damaged", path,
           type, length, left >= 4 ? left - 4 : 0);
    if (type == "IEND") return;
    in.seekg(std::streamoff(length + 4), std::ios::cur);
  }
}

void check_exr_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const auto file_size = fs::file_size(path, ec);
  if (!in || ec) return;  // the reader reports it
  char magic_version[8];
  if (!in.read(magic_version, 8)) return;
  // Attributes: name\0 type\0 int32 size, then size bytes; an empty name ends the header.
  for (int attribute = 0; attribute < 10000; ++attribute) {
    std::string name, type;
    for (std::string* s : {&name, &type}) {
      char c;
      while (in.get(c) && c != '\0' && s->size() < 256) *s += c;
      if (!in) return;
      if (s == &name && name.empty()) return;  // end of the header
    }
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), 4)) return;
    const int64_t size = int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
    const int64_t left = int64_t(file_size) - int64_t(in.tellg());
    if (size < 0 || size > left)
      fail("io", "{}: EXR header attribute '{}' ({}) claims {} bytes, and {} bytes are left in the file", path,
           abbreviate(name, 40), abbreviate(type, 40), size, left);
    // OpenEXR reads a fixed-size type by its type, not by the stated size: a box2i stated as 3
    // bytes made it read on 13 bytes further than this scan, into a "string" of 1.5 GB that it
    // allocated (fuzz_raster, 1.6 GB resident, 9 s). The sizes must agree.
    static const std::map<std::string, int64_t> fixed = {
        {"box2i", 16},     {"box2f", 16},   {"v2i", 8},          {"v2f", 8},        {"v2d", 16},
        {"v3i", 12},       {"v3f", 12},     {"v3d", 24},         {"m33f", 36},      {"m33d", 72},
        {"m44f", 64},      {"m44d", 128},   {"float", 4},        {"double", 8},     {"int", 4},
        {"compression", 1}, {"lineOrder", 1}, {"envmap", 1},     {"deepImageState", 1},
        {"chromaticities", 32}, {"keycode", 28}, {"timecode", 8}, {"rational", 8},  {"tiledesc", 9}};
    if (auto it = fixed.find(type); it != fixed.end() && it->second != size)
      fail("io", "{}: EXR header attribute '{}' ({}) states {} bytes; a {} is {} bytes", path, abbreviate(name, 40), type,
           size, type, it->second);
    // OpenEXR allocates its line buffers from the data window when the file is opened (a 1.7 KB
    // file claiming 11993100 x 2049 cells took 30 s under ASan, fuzz_raster): the raster side
    // limit applies before it does.
    if (name == "dataWindow" && type == "box2i") {
      unsigned char w[16];
      if (!in.read(reinterpret_cast<char*>(w), 16)) return;
      auto i32 = [&](int k) {
        return int64_t(int32_t(uint32_t(w[k]) | uint32_t(w[k + 1]) << 8 | uint32_t(w[k + 2]) << 16 | uint32_t(w[k + 3]) << 24));
      };
      const int64_t width = i32(8) - i32(0) + 1, height = i32(12) - i32(4) + 1;
      if (width < 1 || height < 1 || width > max_raster_side || height > max_raster_side)
        fail("io", "{}: the EXR data window is {} x {} cells; each side must be 1 to {} cells", path, width, height,
             max_raster_side);
      continue;
    }
    in.seekg(size, std::ios::cur);
  }
}

void require_readable(const std::string& path) {
  if (is_virtual_path(path)) return;  // GDAL's open says what is wrong
  std::error_code ec;
  if (!fs::exists(path, ec)) throw MissingFileError("io", fmt::format("{}: no such file", path), path);
  if (fs::is_directory(path, ec)) fail("io", "{}: is a folder, expected a raster file", path);
  if (fs::file_size(path, ec) == 0) fail("io", "{}: file is empty", path);
  if (::access(path.c_str(), R_OK) != 0) fail("io", "{}: not readable ({})", path, std::strerror(errno));
}

void require_writable_folder(const std::string& path) {
  if (is_virtual_path(path)) return;
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
  nlohmann::json j = read_json_file(sc, "io");  // depth and size limits
  if (!j.is_object()) fail("io", "{}: sidecar must be a JSON object", sc);
  return j;
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
  check_cell_size(g, where, "the sidecar's cell_x/cell_y");
}

void check_cell_size(const Georef& g, const std::string& path, const std::string& source) {
  auto ok = [](double c) { return std::isfinite(c) && c >= min_cell_size && c <= max_cell_size; };
  if (!ok(g.cell_x) || !ok(g.cell_y))
    fail("io", "{}: {} gives a cell size of {} x {} m; expected finite sizes within [{:g}, {:g}] m", path, source,
         g.cell_x, g.cell_y, min_cell_size, max_cell_size);
}

void check_finite_or_nodata(const Heightfield& h, const std::string& path, const char* verb) {
  for (size_t i = 0; i < h.z.size(); ++i)
    if (std::isinf(h.z[i]))
      fail("io", "{}: cell ({}, {}) {} an infinite elevation ({}); a DEM must hold finite numbers or nodata (NaN)",
           path, i % size_t(h.width), i / size_t(h.width), verb, h.z[i]);
}

std::string cell_size_source(const Georef& g, const std::string& path, bool from_option) {
  if (from_option) return "--cell-size";
  if (g.has_geotransform) return "the geotransform's pixel size";
  std::ifstream sc(sidecar_path(path));
  if (sc) return "the sidecar " + sidecar_path(path) + " (cell_x/cell_y)";
  return "the terracl:cell_x/cell_y metadata";
}

void check_vertical_range(double zmin, double zmax, const std::string& where) {
  if (!std::isfinite(zmin) || !std::isfinite(zmax) || zmin > zmax)
    fail("io", "{}: the vertical range zmin {} .. zmax {} must be finite with zmin <= zmax", where, zmin, zmax);
}

void check_sidecar_size(const nlohmann::json& sc, const std::string& path, long long width, long long height) {
  for (const auto& [key, actual] : {std::pair<const char*, long long>{"width", width}, {"height", height}}) {
    if (!sc.contains(key)) continue;
    const auto& v = sc.at(key);
    if (!v.is_number_integer() || v.get<long long>() != actual)
      fail("io", "{}: sidecar says {} {}, the image has {}; the sidecar belongs to another file", sidecar_path(path), key,
           abbreviate(v.dump(), 30), actual);
  }
  check_sidecar_image(sc, path);
}

void check_sidecar_image(const nlohmann::json& sc, const std::string& path) {
  // Sidecars written before the check have neither field: they are read as before.
  if (!sc.is_object() || (!sc.contains("image_bytes") && !sc.contains("image_fnv1a64"))) return;
  const std::string sc_name = sidecar_path(path);
  const auto& b = sc.value("image_bytes", nlohmann::json());
  const auto& hsh = sc.value("image_fnv1a64", nlohmann::json());
  if (!b.is_number_unsigned() || !hsh.is_string() || hsh.get<std::string>().size() != 16)
    fail("io", "{}: 'image_bytes' must be a byte count and 'image_fnv1a64' 16 hex digits (they identify the image {})",
         sc_name, path);
  const FileDigest d = file_digest(path);
  const std::string want = hsh.get<std::string>();
  if (d.bytes != b.get<uint64_t>() || hex64(d.fnv1a) != want)
    fail("io", "{} and its sidecar {} do not belong together: the sidecar was written for an image of {} bytes "
         "(FNV-1a {}), the image has {} bytes (FNV-1a {}); one of them was replaced or its write failed, so "
         "write the raster again", path, sc_name, b.get<uint64_t>(), abbreviate(want, 20), d.bytes, hex64(d.fnv1a));
}

std::pair<double, double> finite_range(const std::vector<float>& z) {
  double lo = INFINITY, hi = -INFINITY;
  for (float v : z)
    if (std::isfinite(v)) lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
  if (lo > hi) return {0.0, 0.0};
  return {lo, hi};
}

uint16_t Quantiser::encode(float v) const {
  if (!std::isfinite(v)) return reserve_nodata ? uint16_t(kNodataCode) : uint16_t(0);
  const double lo = reserve_nodata ? 1.0 : 0.0;
  const double span = zmax - zmin;
  const double c = span > 0 ? lo + (double(v) - zmin) / span * (max_code - lo) : lo;
  // A value below zmin (a user-given range) clamps to the lowest data code, never to nodata.
  return uint16_t(std::clamp(std::round(c), lo, max_code));
}

float Quantiser::decode(unsigned code) const {
  if (reserve_nodata && code == kNodataCode) return NAN;
  const double lo = reserve_nodata ? 1.0 : 0.0;
  return float(zmin + (double(code) - lo) / (max_code - lo) * (zmax - zmin));
}

void quantiser_from_sidecar(const nlohmann::json& sc, Quantiser& q, const std::string& sidecar) {
  if (sc.is_null() || !sc.contains("nodata_code") || sc.at("nodata_code").is_null()) return;
  const auto& v = sc.at("nodata_code");
  if (!v.is_number_integer() || v.get<long long>() != kNodataCode)
    fail("io", "{}: nodata_code must be {} (the code terracl reserves for nodata), got {}", sidecar, kNodataCode,
         abbreviate(v.dump(), 30));
  q.reserve_nodata = true;
}

namespace {
std::function<void(const std::string&)>& warning_sink() {
  static std::function<void(const std::string&)> sink;
  return sink;
}
}  // namespace

void warn_sidecarless(const std::string& path, const char* kind) {
  warn(fmt::format("{}: {} without a sidecar ({}): codes are read as metres (0..65535) on 1 m cells; "
                   "give --zmin/--zmax/--cell-size (pipeline read stage: zmin/zmax/cell_size) for the real scale",
                   path, kind, sidecar_path(path)));
}

}  // namespace io

void set_warning_handler(std::function<void(const std::string&)> handler) { io::warning_sink() = std::move(handler); }

void warn(const std::string& message) {
  if (io::warning_sink()) return io::warning_sink()(message);
  std::fprintf(stderr, "terracl: warning: %s\n", message.c_str());
}

namespace {

// Temporary outputs being written, for a signal handler to unlink (SIGTERM, a second Ctrl-C).
// Fixed storage and atomics only: the handler may not allocate or lock.
struct TempSlot {
  std::atomic<int> state{0};  // 0 free, 1 claimed (being filled), 2 holds a live temporary
  char path[4096];
};
TempSlot g_temp_slots[64];

void register_temporary(const std::string& tmp) {
  if (tmp.size() >= sizeof(g_temp_slots[0].path)) return;
  for (auto& s : g_temp_slots) {
    int expected = 0;
    if (!s.state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(s.path, tmp.c_str(), tmp.size() + 1);
    s.state.store(2);
    return;
  }
}

void unregister_temporary(const std::string& tmp) {
  for (auto& s : g_temp_slots)
    if (s.state.load() == 2 && tmp == s.path) {
      s.state.store(0);
      return;
    }
}

}  // namespace

void remove_temporaries_signal_safe() {
  for (auto& s : g_temp_slots)
    if (s.state.load() == 2) ::unlink(s.path);
}

std::string temporary_path_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  // Keep the extension last so that libraries choosing the format by extension still work.
  const std::string name = fmt::format(".{}.tmp{}-{}{}", p.stem().string(), ::getpid(), counter++, p.extension().string());
  const std::string tmp = (p.parent_path() / name).string();
  register_temporary(tmp);
  return tmp;
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  std::error_code ec1, ec2;
  const fs::path ca = fs::weakly_canonical(fs::absolute(a), ec1), cb = fs::weakly_canonical(fs::absolute(b), ec2);
  if (ec1 || ec2) return fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
  return ca == cb;
}

namespace {

// An existing path that a rename would replace although it is not a regular file.
bool exists_not_regular(const std::string& path) {
  struct stat s {};
  return ::stat(path.c_str(), &s) == 0 && !S_ISREG(s.st_mode);
}

}  // namespace

bool is_virtual_path(const std::string& path) noexcept { return path.rfind("/vsi", 0) == 0; }

bool path_exists(const std::string& path, bool regular) noexcept {
  if (is_virtual_path(path)) return true;
  struct stat s {};
  return !path.empty() && ::stat(path.c_str(), &s) == 0 && (!regular || S_ISREG(s.st_mode));
}

void check_path_length(const std::string& stage, const std::string& label, const std::string& path) {
  // The system call stops at a NUL, so "o\0x.tif" wrote a file named "o"; other control
  // characters make names that no one can type or see.
  for (size_t i = 0; i < path.size(); ++i) {
    const auto c = static_cast<unsigned char>(path[i]);
    if (c >= 0x20 && c != 0x7f) continue;
    std::string shown;
    for (unsigned char d : path.substr(0, 80))
      shown += d == 0                      ? std::string("\\0")
               : (d < 0x20 || d == 0x7f) ? fmt::format("\\x{:02x}", d)
                                         : std::string(1, char(d));
    throw UsageError(stage, fmt::format("{} '{}{}': a file name may not hold control characters ({} at byte {}); "
                                        "expected a plain file name",
                                        label, shown, path.size() > 80 ? "..." : "",
                                        c == 0 ? std::string("NUL") : fmt::format("0x{:02x}", c), i));
  }
  size_t longest = 0;
  for (const auto& part : fs::path(path)) longest = std::max(longest, part.string().size());
  // The temporary output name adds ".NAME.tmpPID-N" to the stem: leave room for it.
  if (longest > 200 || path.size() > 4000)
    throw UsageError(stage, fmt::format("{} {}: file name too long ({} characters{}); at most 200 per name and 4000 in all",
                                        label, abbreviate(path, 60), path.size(),
                                        longest > 200 ? fmt::format(", one name of {}", longest) : ""));
}

void check_output_paths(const std::string& stage, const std::vector<NamedPath>& inputs,
                        const std::vector<NamedPath>& outputs) {
  for (const NamedPath& in : inputs)
    if (!in.path.empty()) check_path_length(stage, in.label, in.path);
  for (size_t i = 0; i < outputs.size(); ++i) {
    const NamedPath& o = outputs[i];
    if (o.path.empty()) continue;
    check_path_length(stage, o.label, o.path);
    if (exists_not_regular(o.path))
      throw UsageError(stage, fmt::format("{} {}: exists and is not a regular file (a folder, device or pipe); "
                                          "terracl only replaces regular files",
                                          o.label, o.path));
    for (const NamedPath& in : inputs)
      if (!in.path.empty() && same_file(o.path, in.path))
        throw UsageError(stage, fmt::format("{} {}: is also an input ({}); write to another file", o.label, o.path,
                                            in.label));
    for (size_t j = 0; j < i; ++j)
      if (!outputs[j].path.empty() && same_file(o.path, outputs[j].path))
        throw UsageError(stage, fmt::format("{} {}: is also written by {}; write to another file", o.label, o.path,
                                            outputs[j].label));
  }
}

void commit_temporary(const std::string& tmp, const std::string& path) {
  // Last line of defence (the commands check earlier): never replace a device or a folder.
  if (exists_not_regular(path)) {
    discard_temporary(tmp);
    fail("io", "{}: exists and is not a regular file (a folder, device or pipe); not replaced", path);
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  unregister_temporary(tmp);
  if (ec) {
    const std::string why = ec.message();  // before remove() overwrites ec ("...: Success")
    discard_temporary(tmp);
    fail("io", "cannot move the finished output into place at {}: {}", path, why);
  }
}

void discard_temporary(const std::string& tmp) {
  std::error_code ec;
  fs::remove(tmp, ec);
  unregister_temporary(tmp);
}

void write_text_file_atomic(const std::string& path, const std::string& content) {
  io::require_writable_folder(path);
  write_atomically(path, [&](const std::string& tmp) {
    io::write_file_checked(tmp, content);
  });
}

}  // namespace terracl
