// SPDX-License-Identifier: Apache-2.0
#pragma once
// Row-by-row picture output (render_png.cpp): PNG through libpng's rows, GeoTIFF through
// GDAL. write_image writes all rows at once and the streamed render (render_stream.cpp) one strip
// at a time through the same writer, so both give the same file.
#include <cstdint>
#include <memory>
#include <string>
#include <terracl/heightfield.hpp>

namespace terracl::render {

class PictureWriter {
 public:
  /// Opens `tmp` (the temporary name of `path`, which errors name) for a width x height picture of
  /// `channels` interleaved bytes per pixel; `georef` goes to a GeoTIFF, `meta` to text chunks/tags.
  PictureWriter(const std::string& path, const std::string& tmp, int width, int height, int channels,
                const Georef& georef, const Metadata& meta);
  ~PictureWriter();
  PictureWriter(const PictureWriter&) = delete;
  PictureWriter& operator=(const PictureWriter&) = delete;
  /// Writes rows [y0, y0 + rows) from `pixels` (rows * width * channels bytes); rows come in order.
  void write_rows(int y0, int rows, const uint8_t* pixels);
  /// Finishes the file (throws on a write error); the caller renames it.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
};

}  // namespace terracl::render
