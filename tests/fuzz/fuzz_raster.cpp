// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: the first byte picks a format (.tif .png .exr .r16 .asc .hgt .npy, with or without
// a JSON sidecar), the rest is the file; read_heightfield, and read_gradient for EXR, must answer
// with a heightfield or a terracl Error, never crash, hang or allocate what the header claims.
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/stage_memory.hpp>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

using namespace terracl;

namespace {

void write_file(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  static const char* ext[] = {".tif", ".png", ".exr", ".r16", ".asc", ".hgt", ".npy"};
  const uint8_t pick = data[0];
  const std::string base = "/tmp/terracl-fuzz-" + std::to_string(::getpid());
  // Bits 0-2: the format (7 = .npy, a second .png before .npy existed; 6 still wraps to .tif);
  // bit 3: a sidecar (also read beside a .npy).
  const int format = (pick & 7) == 7 ? 6 : (pick & 7) % 6;
  const std::string path = base + ext[format];
  // With bit 3: the rest up to the first 0xFF byte is a sidecar JSON for PNG/RAW16.
  const uint8_t* body = data + 1;
  size_t body_size = size - 1;
  std::remove((path + ".json").c_str());
  if ((pick & 8) && body_size > 0) {
    size_t cut = 0;
    while (cut < body_size && body[cut] != 0xFF) ++cut;
    write_file(path + ".json", body, cut);
    body += cut < body_size ? cut + 1 : cut;
    body_size -= cut < body_size ? cut + 1 : cut;
  }
  write_file(path, body, body_size);
  // The header probe of the memory column (GDAL opens the file without reading pixels), then the
  // readers themselves.
  (void)raster_shape(path);
  try {
    (void)read_heightfield(path);
  } catch (const Error&) {
  }
  if (format == 2) {
    try {
      if (is_gradient_file(path)) (void)read_gradient(path);
    } catch (const Error&) {
    }
  }
  std::remove(path.c_str());
  std::remove((path + ".json").c_str());
  return 0;
}
