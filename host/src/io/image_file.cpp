// SPDX-License-Identifier: Apache-2.0
#include "io/image_file.hpp"

#include "io/checked_output.hpp"

#include <terracl/error.hpp>

#include <cerrno>
#include <cstring>

namespace terracl::io {

CheckedImageFile::CheckedImageFile(const std::string& tmp) : m_tmp(tmp) {
  m_file = std::fopen(tmp.c_str(), "wb");
  if (!m_file) fail("io", "cannot create {}: {}", output_name(tmp), std::strerror(errno));
}

CheckedImageFile::~CheckedImageFile() {
  if (m_file) std::fclose(m_file);
}

// The first failure's errno is kept: by the time the encoder gives up, errno is long overwritten.
bool CheckedImageFile::write(const void* data, size_t size) noexcept {
  if (m_error) return false;
  if (size && std::fwrite(data, 1, size, m_file) != size) m_error = errno ? errno : EIO;
  return m_error == 0;
}

bool CheckedImageFile::seek(uint64_t offset) noexcept {
  if (m_error) return false;
  if (fseeko(m_file, off_t(offset), SEEK_SET) != 0) m_error = errno ? errno : EIO;
  return m_error == 0;
}

uint64_t CheckedImageFile::tell() noexcept {
  const off_t at = ftello(m_file);
  if (at < 0 && !m_error) m_error = errno ? errno : EIO;
  return at < 0 ? 0 : uint64_t(at);
}

void CheckedImageFile::check(const char* stage) const {
  if (m_error) fail(stage, "writing {} failed: {}", output_name(m_tmp), std::strerror(m_error));
}

void CheckedImageFile::finish(const char* stage) {
  check(stage);
  FILE* f = m_file;
  m_file = nullptr;
  const bool flushed = std::fflush(f) == 0 && !std::ferror(f);
  const int flush_err = errno;
  if (std::fclose(f) != 0 || !flushed)
    fail(stage, "writing {} failed: {}", output_name(m_tmp), std::strerror(flushed ? errno : flush_err));
}

}  // namespace terracl::io
