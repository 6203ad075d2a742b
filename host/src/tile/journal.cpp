// SPDX-License-Identifier: Apache-2.0
// Resume journals (journal.hpp).
#include "tile/journal.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <terracl/error.hpp>

namespace terracl::tile {
namespace fs = std::filesystem;
namespace {
constexpr const char* kMagic = "terracl-tile-journal 1 ";
}

std::string partial_path_for(const std::string& output) {
  const fs::path p(output);
  // The extension stays last (GDAL picks the driver by it), the name hidden as other temporaries.
  return (p.parent_path() / fmt::format(".{}.partial{}", p.stem().string(), p.extension().string())).string();
}

std::string journal_path_for(const std::string& output) { return output + ".journal"; }

TileJournal::TileJournal(std::string path, std::string key) : m_path(std::move(path)), m_key(std::move(key)) {
  // Locked for the run: a second resumable run of the same output would write the same partial file.
  const int fd = ::open(m_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) fail("run", "--resume: cannot open the journal {}: {}", m_path, std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    fail("run", "--resume: {} is locked: another run is writing this output", m_path);
  }
  m_file = ::fdopen(fd, "r+b");
  if (!m_file) {
    ::close(fd);
    fail("run", "--resume: cannot open the journal {}: {}", m_path, std::strerror(errno));
  }
  std::string text;
  char buf[65536];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, m_file)) > 0;) text.append(buf, n);
  const std::string header = kMagic + m_key + "\n";
  if (text.compare(0, header.size(), header) != 0) {
    open_new();
    return;
  }
  // Complete lines only: a run killed while appending leaves a torn last line.
  size_t pos = header.size();
  for (size_t nl; (nl = text.find('\n', pos)) != std::string::npos; pos = nl + 1) {
    std::istringstream line(text.substr(pos, nl - pos));
    size_t tile = 0;
    std::string sum;
    if (!(line >> tile >> sum) || sum.size() != 16) continue;
    try {
      size_t used = 0;
      const uint64_t v = std::stoull(sum, &used, 16);
      if (used == 16) m_entries[tile] = v;
    } catch (const std::exception&) {
    }
  }
  // Rewrite the journal with exactly the complete lines, then append to it.
  open_new();
  for (const auto& [tile, sum] : m_entries) std::fprintf(m_file, "%zu %016llx\n", tile, (unsigned long long)sum);
  std::fflush(m_file);
}

TileJournal::~TileJournal() {
  if (m_file) std::fclose(m_file);
}

void TileJournal::open_new() {
  // Truncated in place (the same descriptor keeps the lock).
  std::fflush(m_file);
  if (::ftruncate(::fileno(m_file), 0) != 0 || std::fseek(m_file, 0, SEEK_SET) != 0 ||
      std::fprintf(m_file, "%s%s\n", kMagic, m_key.c_str()) < 0 || std::fflush(m_file) != 0)
    fail("run", "--resume: cannot write the journal {}: {}", m_path, std::strerror(errno));
}

void TileJournal::restart() {
  m_entries.clear();
  open_new();
}

void TileJournal::record(size_t tile, uint64_t checksum) {
  if (std::fprintf(m_file, "%zu %016llx\n", tile, (unsigned long long)checksum) < 0 || std::fflush(m_file) != 0)
    fail("run", "--resume: cannot write the journal {}: {}", m_path, std::strerror(errno));
}

void TileJournal::remove() {
  std::error_code ec;
  fs::remove(m_path, ec);  // before closing: the lock holds until the name is gone
  if (m_file) std::fclose(m_file);
  m_file = nullptr;
}

}  // namespace terracl::tile
