// Resume journals (journal.hpp).
#include "tile/journal.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
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
  std::ifstream in(m_path, std::ios::binary);
  std::string text;
  if (in) {
    std::ostringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
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
  if (m_file) std::fclose(m_file);
  m_file = std::fopen(m_path.c_str(), "wb");
  if (!m_file) fail("run", "--resume: cannot write the journal {}: {}", m_path, std::strerror(errno));
  std::fprintf(m_file, "%s%s\n", kMagic, m_key.c_str());
  std::fflush(m_file);
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
  if (m_file) std::fclose(m_file);
  m_file = nullptr;
  std::error_code ec;
  fs::remove(m_path, ec);
}

}  // namespace terracl::tile
