// SPDX-License-Identifier: Apache-2.0
#pragma once
// OpenImageIO outputs through a file whose every write and close is checked: OIIO's PNG writer
// closes its FILE without looking at the result, so a full disk gave a truncated PNG, exit 0.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <memory>
#include <string>

namespace terracl::io {

class CheckedImageFile {
 public:
  /// Creates `tmp` (a temporary output name; errors name its output).
  explicit CheckedImageFile(const std::string& tmp);
  ~CheckedImageFile();
  CheckedImageFile(const CheckedImageFile&) = delete;
  CheckedImageFile& operator=(const CheckedImageFile&) = delete;

  /// An ImageOutput for `spec` that writes through this file (opened; errors thrown for `stage`).
  std::unique_ptr<OIIO::ImageOutput> open(const OIIO::ImageSpec& spec, const char* stage);
  /// Throws "<stage>: writing OUTPUT failed: <reason>" when a write failed so far.
  void check(const char* stage) const;
  /// After the ImageOutput's close(): flushes and closes the file, throwing on any error.
  void finish(const char* stage);

 private:
  class Proxy;
  std::string m_tmp;
  FILE* m_file = nullptr;
  std::unique_ptr<Proxy> m_proxy;
};

/// The whole image `data` of `spec` written to `tmp`, every error thrown naming its output.
void write_image_checked(const std::string& tmp, const OIIO::ImageSpec& spec, OIIO::TypeDesc type, const void* data,
                         const char* stage = "io");

}  // namespace terracl::io
