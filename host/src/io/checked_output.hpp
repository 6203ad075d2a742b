#pragma once
// Writes whose every error is seen: a full disk or an I/O error while writing or closing an output
// must fail the run (exit 1, no file under the output's name), never commit a truncated file.
// Messages name the output the user asked for, not the temporary file being written.
#include <cstdint>
#include <memory>
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

/// Size and FNV-1a (64-bit) of a file's bytes: a sidecar stores them so a reader can tell that the
/// image beside it is the one it was written for.
struct FileDigest {
  uint64_t bytes = 0;
  uint64_t fnv1a = 0;
};
FileDigest file_digest(const std::string& path);
std::string hex64(uint64_t v);

}  // namespace terracl::io
