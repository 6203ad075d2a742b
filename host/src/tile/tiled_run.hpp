// SPDX-License-Identifier: Apache-2.0
#pragma once
// The state and helpers of a tiled run (tile_run.cpp: the chains and segments; tile_segment.cpp:
// one segment tile by tile; tiled_run_parts.cpp: windows, sink calls between ranks, journals).
#include <fmt/format.h>
#include <gdal.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>
#include <terracl/tile.hpp>
#include <terracl/version.hpp>

#include "io/gdal_window.hpp"
#include "io/gradient_tiff.hpp"
#include "tile/journal.hpp"
#include "tile/tile_comm.hpp"
#include "tile/tile_sinks.hpp"
#include "tile/warp_tiles.hpp"
#include "io/warp_vrt.hpp"

namespace terracl::tiled {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Win {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  int w() const { return x1 - x0; }
  int h() const { return y1 - y0; }
};
inline Win intersect(const Win& a, const Win& b) {
  return {std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
}
inline Win unite(const Win& a, const Win& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1), std::max(a.y1, b.y1)};
}

// One sink's share of one tile: computed by the tile's rank, written by rank 0 (tile_comm.hpp).
struct SinkCall {
  int op;  // index in the segment's ops; -1: the global stage's temporary input
  int32_t bands = 1;  // 2: a gradient (gx then gy in the payload), written as a 2-band GeoTIFF
  Win core;
  Metadata md;          // the tile's metadata (a writer is created at the first tile that reaches it)
  // `write`, the temporary: GeoTiffWindowWriter::encode(core) (a gradient: gx's then gy's floats);
  // other sinks: what they drew.
  tile::Bytes payload;
};

/// The sink calls of one tile as bytes for rank 0, and back.
tile::Bytes pack_calls(const std::vector<SinkCall>& calls);
std::vector<SinkCall> unpack_calls(const tile::Bytes& b);
/// Band `band` (0-based) of a payload of `bands` w x h float cores.
Heightfield floats_to_core(const tile::Bytes& b, int w, int h, int bands = 1, int band = 0);
/// One journal checksum of a gradient window from its two bands' checksums.
inline uint64_t combine_checksums(uint64_t gx, uint64_t gy) { return (gx ^ 0x9e3779b97f4a7c15ull) * 1099511628211ull ^ gy; }
/// Gradients cropped like heightfields (extract's output in a tile).
GradientField extract_gradient_window(const GradientField& g, const Win& have, const Win& want);
/// Removes the terracl:* provenance keys (each output gets its own).
void drop_terracl_keys(Metadata& md);
/// The georef of a window at (x, y) of a level: the level's, with the corner moved.
Georef georef_at(const Georef& level, int x, int y);
/// Cells `want` (level coordinates) out of `h`, which holds the window `have`.
Heightfield extract(const Heightfield& h, const Win& have, const Win& want, const Georef& level);

struct Level {
  int w = 0, h = 0;
  Georef georef;
};

// The level after a local stage: blocks of f x f cells (downsample) or u x u cells per cell (amplify).
inline Level next_level(const Level& l, int f, int u) {
  if (u > 1) return {l.w * u, l.h * u, l.georef.resampled(u)};
  return {l.w / f, l.h / f, f > 1 ? l.georef.resampled(1.0 / f) : l.georef};
}

// One step of a segment: a stage with its tiling, the level it reads.
struct Op {
  const PipelineStage* st;
  StageTiling tiling;
  int level;  // level of its input (a sink writes this level)
};

struct Segment {
  std::string read_tag;  // the stage its reads are counted to
  std::string stamp;     // --resume: what identifies the source's content (size and time of a file)
  std::shared_ptr<io::GdalWindowReader> source;
  Level level0;
  std::vector<Op> ops;
  Metadata metadata;  // items a global stage made that its file's header does not give back (resize's engine scale)
};

// Whether level l of the segment holds a gradient (the output of an extract; only writers follow).
inline bool gradient_level(const Segment& seg, int l) {
  for (const Op& op : seg.ops)
    if (op.st->type == "extract" && op.level + 1 == l) return true;
  return false;
}

// Runs tile by tile and writes what the run needs: shared state of one run_tiled call.
class TiledRun {
 public:
  TiledRun(const Pipeline& p, const TileOptions& t, const RunOptions& o, RunReport& r)
      : m_p(p), m_t(t), m_o(o), m_report(r) {}
  ~TiledRun() {
    if (tile::comm().rank() != 0) return;  // rank 0 made them (and reads them last)
    for (const auto& f : m_temporaries) {
      std::error_code ec;
      fs::remove(f, ec);
    }
  }

  void run();

 private:
  void run_chain(size_t first, size_t last);
  void run_segment(const Segment& seg, const PipelineStage* global_after, const std::string& global_out,
                   const Metadata& global_metadata);
  using Writers = std::map<const PipelineStage*, std::unique_ptr<io::GeoTiffWindowWriter>>;
  using Journals = std::map<const PipelineStage*, std::unique_ptr<tile::TileJournal>>;
  std::vector<char> prepare_resume(const Segment& seg, const std::vector<Level>& levels,
                                   const std::vector<std::vector<Win>>& cores, int T, Writers& writers,
                                   Journals& journals);
  void add_seconds(const PipelineStage& st, double s) { m_seconds[st.tag] += s; }
  [[noreturn]] void refuse(const PipelineStage& st, const std::string& why) const {
    throw UsageError("run", fmt::format("{}: {}: stage '{}' ({}) cannot run tiled: {}", m_p.source(), st.where, st.tag,
                                        st.type, why));
  }
  /// `per_tile_bytes(T)`, when given, adds what depends on the tile size otherwise (the tiled
  /// fill's perimeter graph, which grows as tiles shrink).
  int tile_size(const Segment& seg, double bytes_per_core_cell, double fixed_bytes,
                const std::function<double(int)>& per_tile_bytes = {}) const;
  Metadata provenance(const PipelineStage& st) const {
    return {{"terracl:version", version()},
            {"terracl:pipeline", m_p.name()},
            {"terracl:pipeline_hash", m_hash},
            {"terracl:stages", m_chain_before.at(st.tag).dump()}};
  }
  Progress progress(const std::string& tag) const {
    return m_o.progress ? m_o.progress(tag, m_progress_index, m_progress_count) : Progress{};
  }

  const Pipeline& m_p;
  const TileOptions& m_t;
  const RunOptions& m_o;
  RunReport& m_report;
  std::string m_hash;
  std::map<std::string, json> m_chain_before;  // tag -> provenance chain of its input
  std::map<std::string, double> m_seconds;
  std::vector<std::string> m_temporaries;
  size_t m_progress_index = 0, m_progress_count = 1;
  std::function<Device&()> m_device;
  std::optional<Level> m_warped;  // the output grid of the last global warp / resize
  Metadata m_warped_metadata;     // and the metadata items it added
  size_t m_kill_after = 0;  // TERRACL_TEST_KILL_AFTER_TILES: SIGKILL after this many tiles (tests of --resume)

 public:
  TileCounts m_counts;
};

// Ctrl-C (the process-wide stop request, interrupt.hpp) is honoured inside a tile, between its
// stages and between its outputs, not only at the progress report after it; a stopped tile is not
/// Ctrl-C (the process-wide stop request, interrupt.hpp) is honoured inside a tile, between its
/// stages and between its outputs; a stopped tile is not journaled, so --resume runs it again.
void stop_point(const std::string& tag);
/// A warp's options are checked before any tile runs (as the untiled stage checks them first).
void io_check_warp(const PipelineStage& st);
/// What identifies a source file's content for a resume journal.
std::string file_stamp(const std::string& path);

}  // namespace terracl::tiled
