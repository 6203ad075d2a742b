// SPDX-License-Identifier: Apache-2.0
#pragma once
// Writes whose every error is seen: a full disk or an I/O error while writing or closing an output
// must fail the run (exit 1, no file under the output's name), never commit a truncated file.
// Messages name the output the user asked for, not the temporary file being written.
#include <cstdint>
#include <memory>
#include <ostream>
#include <string>

namespace terracl::io {

/// The output a temporary name (".NAME.tmpPID-N.ext", ".NAME.partial.ext") stands for; any other
/// name as it is.
std::string output_name(const std::string& path);
/// `message` with every mention of the temporary `tmp` replaced by its output's name (library
/// messages, e.g. GDAL's, name the file they were given).
std::string name_output(std::string message, const std::string& tmp);

/// Writes `size` bytes to `tmp` (created or truncated) and closes it, checking every write and
/// the close; throws "io: writing OUTPUT failed: <reason>".
void write_file_checked(const std::string& tmp, const void* data, size_t size);
inline void write_file_checked(const std::string& tmp, const std::string& bytes) {
  write_file_checked(tmp, bytes.data(), bytes.size());
}

/// An output stream onto `tmp` whose every write and the close are checked, for writers that
/// stream (tinygltf), so that a large output is not held in memory twice. finish() flushes and
/// closes, and throws as write_file_checked does on the first error; the destructor only closes.
class CheckedFileStream {
 public:
  explicit CheckedFileStream(const std::string& tmp);
  ~CheckedFileStream();
  CheckedFileStream(const CheckedFileStream&) = delete;
  CheckedFileStream& operator=(const CheckedFileStream&) = delete;
  std::ostream& stream();
  void finish();

 private:
  struct Buf;
  std::unique_ptr<Buf> m_buf;
  std::unique_ptr<std::ostream> m_stream;
  std::string m_tmp;
};

/// Size and FNV-1a (64-bit) of a file's bytes: a sidecar stores them so a reader can tell that the
/// image beside it is the one it was written for.
struct FileDigest {
  uint64_t bytes = 0;
  uint64_t fnv1a = 0;
};
FileDigest file_digest(const std::string& path);
std::string hex64(uint64_t v);

}  // namespace terracl::io
