// SPDX-License-Identifier: Apache-2.0
#pragma once
// PNG through libpng: what terracl reads (grey elevation codes, two-channel gradient images) and
// writes (16-bit heightfields, 8-bit pictures, gradient images). libpng alone loads in a few
// milliseconds, where a general image library brings its whole plugin set into every start-up.
#include "io/image_file.hpp"

#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace terracl::io::png {

/// What a PNG decodes to: palettes expand to RGB, grey below 8 bits to 8, a tRNS chunk to alpha.
struct Header {
  int width = 0, height = 0;
  int channels = 0;   ///< 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA
  int bit_depth = 0;  ///< 8 or 16
};

struct Pixels {
  Header header;
  /// Rows top to bottom, channels interleaved, samples as stored (no gamma, no premultiplied
  /// alpha): one byte each at depth 8, a native-endian uint16 each at depth 16.
  std::vector<uint8_t> bytes;
  uint16_t sample(size_t i) const {
    if (header.bit_depth == 8) return bytes[i];
    uint16_t v;
    std::memcpy(&v, bytes.data() + 2 * i, 2);
    return v;
  }
};

/// Decodes `path`. `check` sees the header before any pixel memory is allocated and throws to
/// refuse it (a header may claim 100000^2 cells). Errors name `path` and come under `stage`.
Pixels read(const std::string& path, const std::function<void(const Header&)>& check, const char* stage = "io");

using TextChunks = std::vector<std::pair<std::string, std::string>>;

/// Streams a PNG into `file` row by row (rows must come in order and add up to `height`).
class Writer {
 public:
  /// `linear`: a gAMA of 1.0, so viewers show 16-bit codes as they are; `text`: tEXt (or iTXt
  /// for UTF-8) chunks, keys made valid PNG keywords.
  Writer(CheckedImageFile& file, int width, int height, int channels, int bit_depth, const TextChunks& text,
         bool linear, const char* stage);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  /// `rows` full rows, channels interleaved (native-endian uint16 samples at depth 16).
  void write_rows(const void* pixels, int rows);
  /// Writes the end of the file; the caller then finishes `file`.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
};

/// The whole image in one call.
void write(CheckedImageFile& file, int width, int height, int channels, int bit_depth, const void* pixels,
           const TextChunks& text, bool linear, const char* stage);

}  // namespace terracl::io::png
