// SPDX-License-Identifier: Apache-2.0
// NumPy .npy arrays (format versions 1, 2 and 3): a 2-D array, C order, little-endian float32,
// float64, int16 or uint16; rows are north to south as in every terracl raster. No GDAL needed:
// with RAW16 this is what the core build reads and writes. The optional JSON
// sidecar "<file>.npy.json" carries the cell size, georeferencing and metadata (as for RAW16);
// values are elevations as stored, NaN is nodata.
#include "io/io_common.hpp"
#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

namespace terracl::io {
namespace {

constexpr char kMagic[] = "\x93NUMPY";

// The value of `key` in the header's Python dict literal ({'descr': '<f4', 'fortran_order':
// False, 'shape': (3, 4), }), as its source text up to the next top-level ',' or '}'.
std::string dict_value(const std::string& header, const std::string& key, const std::string& path) {
  size_t k = header.find("'" + key + "'");
  if (k == std::string::npos) k = header.find("\"" + key + "\"");
  if (k == std::string::npos) fail("io", "{}: .npy header has no '{}' entry: {}", path, key, abbreviate(header, 80));
  size_t p = header.find(':', k);
  if (p == std::string::npos) fail("io", "{}: .npy header entry '{}' has no value", path, key);
  ++p;
  int depth = 0;
  size_t e = p;
  for (; e < header.size(); ++e) {
    const char c = header[e];
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth == 0 && (c == ',' || c == '}')) break;
  }
  std::string v = header.substr(p, e - p);
  const auto a = v.find_first_not_of(" \t'\""), b = v.find_last_not_of(" \t'\"");
  return a == std::string::npos ? "" : v.substr(a, b - a + 1);
}

struct Dtype {
  char kind = 0;  // 'f', 'i', 'u'
  int bytes = 0;
};

Dtype parse_descr(const std::string& d, const std::string& path) {
  const char* kAccepted = "'<f4' (float32), '<f8' (float64), '<i2' (int16) or '<u2' (uint16)";
  if (d.size() >= 2 && d[0] == '>' && d != ">i1" && d != ">u1")
    fail("io", "{}: .npy dtype '{}' is big-endian; terracl reads little-endian {} (numpy: a.astype('<f4'))", path, abbreviate(d, 40),
         kAccepted);
  if (d == "<f4") return {'f', 4};
  if (d == "<f8") return {'f', 8};
  if (d == "<i2") return {'i', 2};
  if (d == "<u2") return {'u', 2};
  fail("io", "{}: .npy dtype '{}' is not supported; expected {}", path, abbreviate(d, 40), kAccepted);
}

}  // namespace

Heightfield read_npy(const std::string& path, const ReadOptions& opts) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("io", "{}: cannot open", path);
  char pre[10] = {};
  in.read(pre, 10);
  if (!in || std::memcmp(pre, kMagic, 6) != 0)
    fail("io", "{}: not a NumPy .npy file (it must start with \\x93NUMPY)", path);
  const int major = static_cast<unsigned char>(pre[6]);
  if (major < 1 || major > 3) fail("io", "{}: .npy format version {} is not supported (1, 2 or 3)", path, major);
  uint64_t header_len = static_cast<unsigned char>(pre[8]) | (static_cast<unsigned char>(pre[9]) << 8);
  uint64_t offset = 10;
  if (major >= 2) {
    char more[2] = {};
    in.read(more, 2);
    header_len |= uint64_t(static_cast<unsigned char>(more[0])) << 16 | uint64_t(static_cast<unsigned char>(more[1])) << 24;
    offset = 12;
  }
  const uint64_t file_size = std::filesystem::file_size(path);
  if (header_len > 1 << 20 || offset + header_len > file_size)
    fail("io", "{}: .npy header length {} does not fit the {}-byte file", path, header_len, file_size);
  std::string header(header_len, '\0');
  in.read(header.data(), std::streamsize(header_len));
  if (!in) fail("io", "{}: .npy header is truncated", path);
  const Dtype dt = parse_descr(dict_value(header, "descr", path), path);
  const std::string fortran = dict_value(header, "fortran_order", path);
  if (fortran == "True")
    fail("io", "{}: .npy array is in Fortran (column-major) order; terracl reads C order (numpy: "
         "np.ascontiguousarray(a))", path);
  if (fortran != "False") fail("io", "{}: .npy 'fortran_order' must be True or False, got '{}'", path, abbreviate(fortran, 40));
  const std::string shape = dict_value(header, "shape", path);
  // "(H, W)": exactly two positive integers.
  long long dims[3] = {0, 0, 0};
  int nd = 0;
  {
    const char* s = shape.c_str();
    while (*s) {
      if (*s >= '0' && *s <= '9') {
        char* end = nullptr;
        const long long v = std::strtoll(s, &end, 10);
        if (nd < 3) dims[nd] = v;
        ++nd;
        s = end;
      } else {
        ++s;
      }
    }
  }
  // Only digits between the separators: "(-3, 4)" was read as 3 x 4 (the sign skipped).
  const bool plain = shape.find_first_not_of("0123456789 ,()") == std::string::npos;
  if (nd != 2 || !plain)
    fail("io", "{}: .npy 'shape' must be 2-D (rows, columns) of positive integers, got {}", path,
         shape.empty() ? "()" : abbreviate(shape, 60));
  const long long H = dims[0], W = dims[1];
  if (W <= 0 || H <= 0 || W > std::numeric_limits<int>::max() || H > std::numeric_limits<int>::max())
    fail("io", "{}: .npy shape {} has no cells or is too large", path, abbreviate(shape, 60));
  require_raster_size("io", path, W, H, 4 + dt.bytes);
  const uint64_t data_bytes = uint64_t(W) * uint64_t(H) * uint64_t(dt.bytes);
  if (file_size - offset - header_len != data_bytes)
    fail("io", "{}: .npy {} x {} of {}-byte values needs {} data bytes, the file has {}", path, W, H, dt.bytes,
         data_bytes, file_size - offset - header_len);
  std::vector<unsigned char> bytes(data_bytes);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(data_bytes));
  if (!in) fail("io", "{}: read failed", path);

  Heightfield out{int(W), int(H)};
  const size_t n = out.size();
  auto le = [&](size_t i, int nb) {
    uint64_t v = 0;
    for (int b = nb - 1; b >= 0; --b) v = (v << 8) | bytes[i * size_t(nb) + size_t(b)];
    return v;
  };
  for (size_t i = 0; i < n; ++i) {
    if (dt.kind == 'f' && dt.bytes == 4) {
      const uint32_t v = uint32_t(le(i, 4));
      std::memcpy(&out.z[i], &v, 4);
    } else if (dt.kind == 'f') {
      const uint64_t v = le(i, 8);
      double d;
      std::memcpy(&d, &v, 8);
      if (std::isfinite(d) && std::fabs(d) > double(std::numeric_limits<float>::max()))
        fail("io", "{}: value {} at cell ({}, {}) does not fit float32", path, d, i % size_t(W), i / size_t(W));
      out.z[i] = float(d);
    } else if (dt.kind == 'i') {
      out.z[i] = float(int16_t(uint16_t(le(i, 2))));
    } else {
      out.z[i] = float(uint16_t(le(i, 2)));
    }
  }
  const nlohmann::json sc = read_sidecar(path);
  if (!sc.is_null()) {
    check_sidecar_size(sc, path, W, H);
    georef_from_json(sc, out.georef, sidecar_path(path));
    if (sc.contains("metadata") && sc["metadata"].is_object())
      for (auto& [k, v] : sc["metadata"].items())
        if (v.is_string()) out.metadata[k] = v.get<std::string>();
  }
  if (opts.cell_size) out.georef.cell_x = out.georef.cell_y = *opts.cell_size;
  return out;
}

void write_npy(const Heightfield& h, const std::string& tmp_path) {
  // Version 1.0, '<f4', C order; magic + lengths + header padded with spaces to a multiple of 64
  // bytes and ended by '\n', as numpy.save writes it.
  std::string header = fmt::format("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}), }}", h.height, h.width);
  const size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  std::string pre(kMagic, 6);
  pre.push_back('\x01');
  pre.push_back('\x00');
  pre.push_back(char(header.size() & 0xff));
  pre.push_back(char(header.size() >> 8));
  std::vector<unsigned char> bytes(h.size() * 4);
  for (size_t i = 0; i < h.size(); ++i) {
    uint32_t v;
    std::memcpy(&v, &h.z[i], 4);
    for (int b = 0; b < 4; ++b) bytes[4 * i + size_t(b)] = static_cast<unsigned char>(v >> (8 * b));
  }
  std::string file = pre + header;
  file.append(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  write_file_checked(tmp_path, file);
}

}  // namespace terracl::io
