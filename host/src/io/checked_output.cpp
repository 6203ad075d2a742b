// SPDX-License-Identifier: Apache-2.0
#include "io/checked_output.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

namespace terracl::io {
namespace fs = std::filesystem;

namespace {

bool all_digits(const std::string& s) { return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos; }

}  // namespace

std::string output_name(const std::string& path) {
  const fs::path p(path);
  const std::string name = p.filename().string();
  if (name.size() < 2 || name[0] != '.') return path;
  const std::string ext = p.extension().string();  // the temporary keeps the output's extension
  const std::string body = name.substr(1, name.size() - 1 - ext.size());
  std::string stem;
  if (const size_t k = body.rfind(".tmp"); k != std::string::npos) {
    // ".STEM.tmpPID-N.ext" (temporary_path_for)
    const std::string id = body.substr(k + 4);
    const size_t dash = id.find('-');
    if (dash != std::string::npos && all_digits(id.substr(0, dash)) && all_digits(id.substr(dash + 1)))
      stem = body.substr(0, k);
  }
  if (stem.empty() && body.size() > 8 && body.compare(body.size() - 8, 8, ".partial") == 0)
    stem = body.substr(0, body.size() - 8);  // ".STEM.partial.ext" (resumable tiled runs)
  if (stem.empty()) return path;
  return (p.parent_path() / (stem + ext)).string();
}

std::string name_output(std::string message, const std::string& tmp) {
  const std::string out = output_name(tmp);
  if (tmp.empty() || out == tmp) return message;
  for (size_t at = message.find(tmp); at != std::string::npos; at = message.find(tmp, at + out.size()))
    message.replace(at, tmp.size(), out);
  return message;
}

void write_file_checked(const std::string& tmp, const void* data, size_t size) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) fail("io", "cannot create {}: {}", output_name(tmp), std::strerror(errno));
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;  // a write of 0 bytes: the device took nothing
      ::close(fd);
      fail("io", "writing {} failed: {}", output_name(tmp), std::strerror(err));
    }
    p += n;
    left -= size_t(n);
  }
  // close() reports what a network or quota-limited file system only finds out at the end.
  if (::close(fd) != 0) fail("io", "writing {} failed: {}", output_name(tmp), std::strerror(errno));
}

// A streambuf onto a file descriptor that keeps the first error instead of losing it in a
// buffered flush (std::ofstream reports no reason, tinygltf checks nothing).
struct CheckedFileStream::Buf : std::streambuf {
  int fd = -1;
  int error = 0;
  std::vector<char> buffer = std::vector<char>(size_t(1) << 20);
  Buf() { setp(buffer.data(), buffer.data() + buffer.size()); }
  bool drain() {
    const char* p = pbase();
    size_t left = size_t(pptr() - pbase());
    while (left > 0 && error == 0) {
      const ssize_t n = ::write(fd, p, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) error = n < 0 ? errno : ENOSPC;
      else p += n, left -= size_t(n);
    }
    setp(buffer.data(), buffer.data() + buffer.size());
    return error == 0;
  }
  int_type overflow(int_type c) override {
    if (!drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return drain() ? 0 : -1; }
};

CheckedFileStream::CheckedFileStream(const std::string& tmp) : m_buf(std::make_unique<Buf>()), m_tmp(tmp) {
  m_buf->fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (m_buf->fd < 0) fail("io", "cannot create {}: {}", output_name(tmp), std::strerror(errno));
  m_stream = std::make_unique<std::ostream>(m_buf.get());
}

CheckedFileStream::~CheckedFileStream() {
  if (m_buf->fd >= 0) ::close(m_buf->fd);
}

std::ostream& CheckedFileStream::stream() { return *m_stream; }

void CheckedFileStream::finish() {
  m_buf->drain();
  const int fd = m_buf->fd;
  m_buf->fd = -1;
  // close() reports what a network or quota-limited file system only finds out at the end.
  if (::close(fd) != 0 && m_buf->error == 0) m_buf->error = errno;
  if (m_buf->error) fail("io", "writing {} failed: {}", output_name(m_tmp), std::strerror(m_buf->error));
}

FileDigest file_digest(const std::string& path) {
  FileDigest d;
  d.fnv1a = 0xcbf29ce484222325ull;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail("io", "cannot read {}: {}", output_name(path), std::strerror(errno));
  std::vector<unsigned char> buf(1 << 20);
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      fail("io", "cannot read {}: {}", output_name(path), std::strerror(err));
    }
    if (n == 0) break;
    for (ssize_t i = 0; i < n; ++i) d.fnv1a = (d.fnv1a ^ buf[size_t(i)]) * 0x100000001b3ull;
    d.bytes += uint64_t(n);
  }
  ::close(fd);
  return d;
}

std::string hex64(uint64_t v) { return fmt::format("{:016x}", v); }

}  // namespace terracl::io
