// SPDX-License-Identifier: Apache-2.0
// encode_float_block (gdal_window.hpp): a 256^2 float32 block compressed by libtiff itself, in a
// TIFF held in memory, with the tags GDAL's GTiff driver sets for the window writer's files
// (tiled 256^2, float32, one band, DEFLATE, PREDICTOR=3, ZLEVEL=kDeflateLevel): libtiff then runs
// the same predictor and DEFLATE code at the same level, so the bytes are those GDAL would have
// written.
#include <tiffio.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <terracl/error.hpp>

#include "io/gdal_window.hpp"

namespace terracl::io {
namespace {

struct MemoryFile {
  std::vector<uint8_t> bytes;
  uint64_t at = 0;
};

tmsize_t mem_read(thandle_t h, void* dst, tmsize_t n) {
  auto* m = static_cast<MemoryFile*>(h);
  const uint64_t left = m->at < m->bytes.size() ? m->bytes.size() - m->at : 0;
  const auto k = tmsize_t(std::min<uint64_t>(uint64_t(n), left));
  if (k > 0) std::memcpy(dst, m->bytes.data() + m->at, size_t(k));
  m->at += uint64_t(k);
  return k;
}
tmsize_t mem_write(thandle_t h, void* src, tmsize_t n) {
  auto* m = static_cast<MemoryFile*>(h);
  if (m->at + uint64_t(n) > m->bytes.size()) m->bytes.resize(size_t(m->at + uint64_t(n)));
  std::memcpy(m->bytes.data() + m->at, src, size_t(n));
  m->at += uint64_t(n);
  return n;
}
toff_t mem_seek(thandle_t h, toff_t off, int whence) {
  auto* m = static_cast<MemoryFile*>(h);
  if (whence == SEEK_CUR) off += m->at;
  if (whence == SEEK_END) off += m->bytes.size();
  m->at = off;
  return off;
}
int mem_close(thandle_t) { return 0; }
toff_t mem_size(thandle_t h) { return static_cast<MemoryFile*>(h)->bytes.size(); }
int mem_map(thandle_t, void**, toff_t*) { return 0; }
void mem_unmap(thandle_t, void*, toff_t) {}

}  // namespace

std::vector<uint8_t> encode_float_block(const float* cells) {
  constexpr int B = 256;
  MemoryFile m;
  TIFF* t =
      TIFFClientOpen("terracl-block", "w", &m, mem_read, mem_write, mem_seek, mem_close, mem_size, mem_map, mem_unmap);
  if (!t) fail("io", "internal: libtiff cannot open a block in memory");
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, B);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, B);
  TIFFSetField(t, TIFFTAG_TILEWIDTH, B);
  TIFFSetField(t, TIFFTAG_TILELENGTH, B);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 32);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  TIFFSetField(t, TIFFTAG_PREDICTOR, PREDICTOR_FLOATINGPOINT);
  TIFFSetField(t, TIFFTAG_ZIPQUALITY, kDeflateLevel);
  // libtiff's predictor works on a copy, but the call takes a non-const buffer.
  std::vector<float> copy(cells, cells + size_t(B) * B);
  const bool ok =
      TIFFWriteEncodedTile(t, 0, copy.data(), tmsize_t(copy.size() * sizeof(float))) >= 0 && TIFFFlushData(t) == 1;
  const uint64_t off = ok ? TIFFGetStrileOffset(t, 0) : 0, n = ok ? TIFFGetStrileByteCount(t, 0) : 0;
  TIFFClose(t);
  if (!ok || n == 0 || off + n > m.bytes.size()) fail("io", "internal: libtiff could not compress a block");
  return {m.bytes.begin() + std::ptrdiff_t(off), m.bytes.begin() + std::ptrdiff_t(off + n)};
}

}  // namespace terracl::io
