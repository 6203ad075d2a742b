// SPDX-License-Identifier: Apache-2.0
#pragma once
// The file under a PNG or EXR being written, every write, seek and the close checked: an image
// encoder that ignores a short write (a full disk) would otherwise leave a truncated image, exit 0.
#include <cstdint>
#include <cstdio>
#include <string>

namespace terracl::io {

class CheckedImageFile {
 public:
  /// Creates `tmp` (a temporary output name; errors name its output).
  explicit CheckedImageFile(const std::string& tmp);
  ~CheckedImageFile();
  CheckedImageFile(const CheckedImageFile&) = delete;
  CheckedImageFile& operator=(const CheckedImageFile&) = delete;

  /// The encoders' callbacks: false (and the first errno kept) on failure, never a throw, since
  /// libpng calls them from C.
  bool write(const void* data, size_t size) noexcept;
  bool seek(uint64_t offset) noexcept;
  uint64_t tell() noexcept;
  /// Throws "<stage>: writing OUTPUT failed: <reason>" when a write failed so far.
  void check(const char* stage) const;
  /// After the encoder finished: flushes and closes the file, throwing on any error.
  void finish(const char* stage);
  const std::string& tmp() const { return m_tmp; }

 private:
  std::string m_tmp;
  FILE* m_file = nullptr;
  int m_error = 0;
};

}  // namespace terracl::io
