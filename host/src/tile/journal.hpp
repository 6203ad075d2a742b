// SPDX-License-Identifier: Apache-2.0
#pragma once
// Resume journals of tiled runs (`--resume`, docs/scale.md): one text file beside each output,
// "<output>.journal", that names the run (a key: pipeline hash, tile size, halo, sizes, source) and
// lists every tile whose core the output's partial file holds, with the checksum of those cells:
//
//   terracl-tile-journal 1 <key>
//   <tile index> <checksum, 16 hex digits>
//
// A line is appended (and flushed) only after the partial file was flushed, so a killed run's
// journal never names a tile the file lacks; a torn last line is ignored.
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>

namespace terracl::tile {

/// The fixed temporary name of an output of a resumable run (".NAME.partial.EXT" beside it).
std::string partial_path_for(const std::string& output);
/// "<output>.journal".
std::string journal_path_for(const std::string& output);

class TileJournal {
 public:
  /// Reads the journal at `path` when it names the run `key` (entries()), else starts a new one.
  TileJournal(std::string path, std::string key);
  ~TileJournal();
  TileJournal(const TileJournal&) = delete;
  TileJournal& operator=(const TileJournal&) = delete;
  /// Tiles recorded by an earlier run of the same key: index -> checksum.
  const std::map<size_t, uint64_t>& entries() const { return m_entries; }
  /// Forgets the earlier run's tiles (its partial file could not be reused): a new journal.
  void restart();
  /// Appends a finished tile and flushes the journal.
  void record(size_t tile, uint64_t checksum);
  /// Deletes the journal (the output is complete).
  void remove();

 private:
  void open_new();
  std::string m_path, m_key;
  std::map<size_t, uint64_t> m_entries;
  std::FILE* m_file = nullptr;
};

}  // namespace terracl::tile
