// SPDX-License-Identifier: Apache-2.0
#include "io/oiio_checked.hpp"

#include "io/checked_output.hpp"

#include <terracl/error.hpp>

#include <cerrno>
#include <cstring>

namespace terracl::io {

// The first failed write's errno is kept: the image library may ignore the short count, and
// errno is long overwritten by the time it closes the file.
class CheckedImageFile::Proxy : public OIIO::Filesystem::IOFile {
 public:
  explicit Proxy(FILE* f) : IOFile(f, Write) {}
  size_t write(const void* buf, size_t size) override { return note(IOFile::write(buf, size), size); }
  size_t pwrite(const void* buf, size_t size, int64_t offset) override {
    return note(IOFile::pwrite(buf, size, offset), size);
  }
  int error = 0;

 private:
  size_t note(size_t done, size_t size) {
    if (done != size && !error) error = errno ? errno : EIO;
    return done;
  }
};

CheckedImageFile::CheckedImageFile(const std::string& tmp) : m_tmp(tmp) {
  m_file = std::fopen(tmp.c_str(), "wb");
  if (!m_file) fail("io", "cannot create {}: {}", output_name(tmp), std::strerror(errno));
  m_proxy = std::make_unique<Proxy>(m_file);
}

CheckedImageFile::~CheckedImageFile() {
  m_proxy.reset();
  if (m_file) std::fclose(m_file);
}

std::unique_ptr<OIIO::ImageOutput> CheckedImageFile::open(const OIIO::ImageSpec& spec, const char* stage) {
  const std::string out_name = output_name(m_tmp);
  auto out = OIIO::ImageOutput::create(m_tmp);
  if (!out) fail(stage, "cannot write {}: {}", out_name, name_output(OIIO::geterror(), m_tmp));
  if (!out->supports("ioproxy"))
    fail(stage, "cannot write {}: this OpenImageIO's {} writer cannot report write errors (no ioproxy support)",
         out_name, out->format_name());
  if (!out->set_ioproxy(m_proxy.get()) || !out->open(m_tmp, spec)) {
    check(stage);
    fail(stage, "cannot write {}: {}", out_name, name_output(out->geterror(), m_tmp));
  }
  return out;
}

void CheckedImageFile::check(const char* stage) const {
  if (m_proxy && m_proxy->error)
    fail(stage, "writing {} failed: {}", output_name(m_tmp), std::strerror(m_proxy->error));
}

void CheckedImageFile::finish(const char* stage) {
  check(stage);
  m_proxy.reset();
  FILE* f = m_file;
  m_file = nullptr;
  const bool flushed = std::fflush(f) == 0 && !std::ferror(f);
  const int flush_err = errno;
  if (std::fclose(f) != 0 || !flushed)
    fail(stage, "writing {} failed: {}", output_name(m_tmp), std::strerror(flushed ? errno : flush_err));
}

void write_image_checked(const std::string& tmp, const OIIO::ImageSpec& spec, OIIO::TypeDesc type, const void* data,
                         const char* stage) {
  CheckedImageFile file(tmp);
  auto out = file.open(spec, stage);
  const bool wrote = out->write_image(type, data);
  file.check(stage);
  if (!wrote) fail(stage, "writing {} failed: {}", output_name(tmp), name_output(out->geterror(), tmp));
  const bool closed = out->close();
  file.check(stage);
  if (!closed) fail(stage, "writing {} failed: {}", output_name(tmp), name_output(out->geterror(), tmp));
  out.reset();
  file.finish(stage);
}

}  // namespace terracl::io
