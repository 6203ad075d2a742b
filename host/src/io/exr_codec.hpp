// SPDX-License-Identifier: Apache-2.0
#pragma once
// EXR through OpenEXR: float heightfields and two-channel gradient fields with terracl's string
// attributes. Compression and decompression use OpenEXR's thread pool (one thread per core).
#include "io/image_file.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace terracl::io::exr {

struct Header {
  int width = 0, height = 0;            ///< of the data window
  std::vector<std::string> channels;    ///< in file order (alphabetical)
  bool all_float = true;                ///< every channel HALF or FLOAT (else integer codes, UINT)
  std::vector<std::pair<std::string, std::string>> strings;  ///< string attributes
};

class Reader {
 public:
  /// Opens `path` (errors "<stage>: <path>: ..."); call check_exr_header first on untrusted files.
  Reader(const std::string& path, const char* stage = "io");
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  const Header& header() const;
  /// Rows [y0, y1) of `channels` (names), interleaved, as float.
  void read_float(int y0, int y1, const std::vector<std::string>& channels, float* out);
  /// Rows [y0, y1) of one channel as 32-bit unsigned integers.
  void read_uint(int y0, int y1, const std::string& channel, uint32_t* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
};

struct Attributes {
  std::vector<std::pair<std::string, std::string>> strings;
  std::vector<std::pair<std::string, float>> floats;
};

/// Writes a ZIP-compressed float EXR of `channels` (interleaved in `pixels`) into `file`.
void write_float(CheckedImageFile& file, int width, int height, const std::vector<std::string>& channels,
                 const float* pixels, const Attributes& attributes, const char* stage = "io");

}  // namespace terracl::io::exr
