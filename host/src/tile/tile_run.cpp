// Tiled, out-of-core pipeline runs (`terracl run P.json --tile N`, docs/scale.md).
//
// A chain (a reader and the stages after it) is cut into segments at its global stages. A segment
// is run tile by tile: the tiles partition the segment's source grid; for each tile, the windows
// every level needs are found backwards from the tile's core at each writer (a local stage needs
// its footprint as a halo, a downsample whole blocks, a crop a shifted window), the first window
// is read through GDAL, each stage runs on its window exactly as it would on the whole raster,
// and each writer receives the tile's core. Cells within a stage's footprint of a window edge that
// is not the raster's edge are wrong and are never written; every written cell saw all the cells
// it depends on, with the whole raster's georeferencing (metric cell size included), so local
// stages give the untiled result bit for bit. A sink with a footprint (render) receives its core
// plus that halo (tile_sinks.hpp). A global stage (fill_depressions) runs its own
// exact tiled algorithm from the previous segment's output (a temporary tiled GeoTIFF, or the
// source itself) into the next segment's source.
#include <fmt/format.h>
#include <gdal.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
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

namespace terracl {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

struct Win {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  int w() const { return x1 - x0; }
  int h() const { return y1 - y0; }
};
Win intersect(const Win& a, const Win& b) {
  return {std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
}
Win unite(const Win& a, const Win& b) {
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

tile::Bytes pack_calls(const std::vector<SinkCall>& calls) {
  tile::ByteWriter w;
  w.put(uint64_t(calls.size()));
  for (const SinkCall& c : calls) {
    w.put(int32_t(c.op)).put(c.bands).put(c.core);
    w.put(uint64_t(c.md.size()));
    for (const auto& [k, v] : c.md) w.put_string(k).put_string(v);
    w.put_vector(c.payload);
  }
  return std::move(w.bytes());
}

std::vector<SinkCall> unpack_calls(const tile::Bytes& b) {
  tile::ByteReader r(b);
  std::vector<SinkCall> calls(size_t(r.get<uint64_t>()));
  for (SinkCall& c : calls) {
    c.op = r.get<int32_t>();
    c.bands = r.get<int32_t>();
    c.core = r.get<Win>();
    for (uint64_t n = r.get<uint64_t>(); n > 0; --n) {
      std::string k = r.get_string();
      c.md[k] = r.get_string();
    }
    c.payload = r.get_vector<uint8_t>();
  }
  return calls;
}

// Band `band` (0-based) of a payload of `bands` w x h float cores.
Heightfield floats_to_core(const tile::Bytes& b, int w, int h, int bands = 1, int band = 0) {
  Heightfield core(w, h);
  const size_t n = core.z.size() * sizeof(float);
  if (b.size() != n * size_t(bands))
    throw Error("tile", fmt::format("internal: a {} x {} x {} core arrived as {} bytes", w, h, bands, b.size()));
  std::memcpy(core.z.data(), b.data() + n * size_t(band), n);
  return core;
}

// One journal checksum of a gradient window from its two bands' checksums.
uint64_t combine_checksums(uint64_t gx, uint64_t gy) { return (gx ^ 0x9e3779b97f4a7c15ull) * 1099511628211ull ^ gy; }

// Gradients cropped like heightfields (extract's output in a tile).
GradientField extract_gradient_window(const GradientField& g, const Win& have, const Win& want) {
  if (want.x0 < have.x0 || want.y0 < have.y0 || want.x1 > have.x1 || want.y1 > have.y1)
    throw Error("tile", "internal: gradient window outside the computed one");
  GradientField out(want.w(), want.h());
  for (int y = 0; y < out.height; ++y) {
    const size_t from = size_t(want.y0 - have.y0 + y) * g.width + size_t(want.x0 - have.x0);
    std::copy_n(&g.gx[from], out.width, &out.gx[size_t(y) * out.width]);
    std::copy_n(&g.gy[from], out.width, &out.gy[size_t(y) * out.width]);
  }
  out.georef = g.georef;
  out.metadata = g.metadata;
  out.mean_elevation = g.mean_elevation;
  return out;
}

void drop_terracl_keys(Metadata& md) {
  for (auto it = md.begin(); it != md.end();) it = it->first.rfind("terracl:", 0) == 0 ? md.erase(it) : std::next(it);
}

// The georef of a window at (x, y) of a level: the level's, with the corner moved.
Georef georef_at(const Georef& level, int x, int y) {
  Georef g = level;
  if (g.has_geotransform) {
    auto& gt = g.geotransform;
    gt[0] += x * gt[1] + y * gt[2];
    gt[3] += x * gt[4] + y * gt[5];
  }
  return g;
}

// Cells `want` (level coordinates) out of `h`, which holds the window `have`.
Heightfield extract(const Heightfield& h, const Win& have, const Win& want, const Georef& level) {
  if (want.x0 < have.x0 || want.y0 < have.y0 || want.x1 > have.x1 || want.y1 > have.y1)
    throw Error("tile", fmt::format("internal: window {},{}-{},{} outside {},{}-{},{}", want.x0, want.y0, want.x1,
                                    want.y1, have.x0, have.y0, have.x1, have.y1));
  Heightfield out(want.w(), want.h());
  for (int y = 0; y < out.height; ++y)
    std::copy_n(&h.z[size_t(want.y0 - have.y0 + y) * h.width + size_t(want.x0 - have.x0)], out.width,
                &out.z[size_t(y) * out.width]);
  out.georef = georef_at(level, want.x0, want.y0);
  out.metadata = h.metadata;
  return out;
}

struct Level {
  int w = 0, h = 0;
  Georef georef;
};

// The level after a local stage: blocks of f x f cells (downsample) or u x u cells per cell (amplify).
Level next_level(const Level& l, int f, int u) {
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
bool gradient_level(const Segment& seg, int l) {
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
  int tile_size(const Segment& seg, double bytes_per_core_cell, double fixed_bytes) const;
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
// journaled, so --resume runs it again.
void stop_point(const std::string& tag) {
  if (stop_requested()) throw Cancelled(tag, "cancelled");
}

// A warp's options are checked before any tile runs (as the untiled stage checks them first).
void io_check_warp(const PipelineStage& st) { io::check_warp_options(tile::warp_options_of(st), st.tag); }

// What identifies a source file's content for a resume journal.
std::string file_stamp(const std::string& path) {
  std::error_code e1, e2;
  const auto size = fs::file_size(path, e1);
  const auto time = fs::last_write_time(path, e2);
  if (e1 || e2) return path;
  return fmt::format("{} {} {}", path, size, time.time_since_epoch().count());
}

// --resume: opens each writer's journal; a writer whose journal names this run reopens its partial
// output, and a tile counts as finished when every writer it reaches holds its cells with the
// journaled checksum. Returns, per tile, whether it is finished (1).
std::vector<char> TiledRun::prepare_resume(const Segment& seg, const std::vector<Level>& levels,
                                           const std::vector<std::vector<Win>>& cores, int T, Writers& writers,
                                           Journals& journals) {
  const std::string key = fmt::format("pipeline {} tile {} halo {} source {} tiles {}", m_hash, T,
                                      m_t.halo ? std::to_string(*m_t.halo) : "auto", seg.stamp, cores.size());
  std::vector<char> done(cores.size(), 0);
  bool any_writer = false;
  for (const Op& op : seg.ops)
    if (op.tiling.kind == TileKind::Sink && op.st->type == "write") any_writer = true;
  if (!any_writer) return done;
  std::fill(done.begin(), done.end(), 1);
  for (const Op& op : seg.ops) {
    if (op.tiling.kind != TileKind::Sink || op.st->type != "write") continue;
    const std::string f = op.st->options.at("filename").get<std::string>();
    const Level& L = levels[op.level];
    const int bands = gradient_level(seg, op.level) ? 2 : 1;
    auto& j = journals[op.st];
    j = std::make_unique<tile::TileJournal>(tile::journal_path_for(f), fmt::format("{} level {} x {}", key, L.w, L.h));
    const std::string partial = tile::partial_path_for(f);
    if (!j->entries().empty()) {
      // Reopened as it is (its metadata were written when it was created).
      auto wr = std::make_unique<io::GeoTiffWindowWriter>(f, L.w, L.h, L.georef, Metadata{}, partial, bands);
      if (wr->reopened()) {
        writers[op.st] = std::move(wr);
      } else {
        j->restart();
      }
    }
    if (j->entries().empty()) {
      writers.erase(op.st);
      std::error_code ec;
      fs::remove(partial, ec);
    }
    io::GeoTiffWindowWriter* wr = writers.count(op.st) ? writers[op.st].get() : nullptr;
    for (size_t ti = 0; ti < cores.size(); ++ti) {
      const Win& c = cores[ti][op.level];
      if (c.empty() || !done[ti]) continue;
      const auto it = j->entries().find(ti);
      if (it == j->entries().end() || !wr) {
        done[ti] = 0;
      } else if ((bands == 2 ? combine_checksums(wr->checksum(c.x0, c.y0, c.w(), c.h(), 1),
                                                 wr->checksum(c.x0, c.y0, c.w(), c.h(), 2))
                             : wr->checksum(c.x0, c.y0, c.w(), c.h())) != it->second) {
        done[ti] = 0;
        ++m_counts.mismatched;
      }
    }
  }
  return done;
}

int TiledRun::tile_size(const Segment& seg, double bytes_per_core_cell, double fixed_bytes) const {
  int align = 1;
  for (const Op& op : seg.ops)
    if (op.tiling.kind == TileKind::Local) align *= op.tiling.down;
  auto fits = [&](double T) { return fixed_bytes + bytes_per_core_cell * T * T; };
  int T = m_t.tile;
  if (T <= 0) {
    T = 2048;
    if (m_t.memory_budget > 0) {
      // The largest multiple of 256 whose tile fits in the half of the budget GDAL's cache leaves.
      T = 256;
      while (T < 16384 && fits(T + 256) <= 0.5 * double(m_t.memory_budget)) T += 256;
    }
  }
  T = (T + align - 1) / align * align;
  if (m_t.memory_budget > 0 && fits(T) > 0.5 * double(m_t.memory_budget))
    throw UsageError("run", fmt::format("--memory-budget {}: a {} x {} tile needs about {} (half the budget goes to "
                                        "tiles, a quarter to GDAL's cache); use a smaller --tile or a larger budget",
                                        human_bytes(double(m_t.memory_budget)), T, T, human_bytes(fits(T))));
  return T;
}

void TiledRun::run() {
  if (m_t.tile < 0) throw UsageError("run", fmt::format("--tile must be a positive number of cells, got {}", m_t.tile));
  if (m_t.halo && *m_t.halo < 0) throw UsageError("run", fmt::format("--halo must be >= 0 or auto, got {}", *m_t.halo));
  m_hash = m_p.hash();
  if (const char* k = std::getenv("TERRACL_TEST_KILL_AFTER_TILES")) m_kill_after = std::strtoull(k, nullptr, 10);
  for (const auto& f : m_p.outputs()) {
    const fs::path dir = fs::path(f).parent_path();
    std::error_code ec;
    if (!dir.empty()) fs::create_directories(dir, ec);
    if (ec) fail("run", "cannot create the output folder {}: {}", dir.string(), ec.message());
  }
  m_device = m_o.device;
  if (!m_device) {  // as Pipeline::run: opened on first use (render, erode)
    auto opened = std::make_shared<std::shared_ptr<Device>>();
    m_device = [opened]() -> Device& {
      if (!*opened) *opened = Device::open();
      return **opened;
    };
  }
  // GDAL's block cache defaults to 5 % of RAM: bound it by the budget.
  const uint64_t cache = m_t.memory_budget > 0 ? m_t.memory_budget / 4 : uint64_t(256) << 20;
  GDALSetCacheMax64(GIntBig(cache));
  // Tileability first, so that a refusal costs nothing.
  const auto& stages = m_p.stages();
  json chain = json::array();
  for (const auto& st : stages) {
    if (st.info->input == DataKind::None) chain = json::array();
    m_chain_before[st.tag] = chain;
    if (st.type != "write") {
      json set = json::object();
      for (auto& [k, v] : st.options.items())
        if (!v.is_null()) set[k] = v;
      chain.push_back(json{{"type", st.type}, {"tag", st.tag}, {"options", set}});
    }
    const StageTiling tl = tiling_of(st);
    if (tl.kind == TileKind::Untileable) refuse(st, tl.limit);
    if (m_t.resume && tl.kind == TileKind::Sink && st.type != "write")
      throw UsageError("run", fmt::format("{}: {}: stage '{}' ({}) cannot --resume: it builds its picture or report in a file "
                                          "of its own that keeps no journal; run without --resume",
                                          m_p.source(), st.where, st.tag, st.type));
    if (st.info->input == DataKind::None && tl.kind != TileKind::Source)
      refuse(st, "a tiled chain starts with a reader");
  }
  size_t first = 0;
  for (size_t i = 1; i <= stages.size(); ++i)
    if (i == stages.size() || stages[i].info->input == DataKind::None) {
      run_chain(first, i);
      first = i;
    }
  for (const auto& st : stages) m_report.stages.push_back(StageRun{st.type, st.tag, m_seconds[st.tag], st.outputs});
  m_report.running.clear();
}

void TiledRun::run_chain(size_t first, size_t last) {
  const auto& stages = m_p.stages();
  const PipelineStage& reader = stages[first];
  m_report.running = reader.tag;
  auto t0 = Clock::now();
  Segment seg;
  seg.read_tag = reader.tag;
  seg.source = std::make_shared<io::GdalWindowReader>(reader.options.at("filename").get<std::string>());
  seg.stamp = file_stamp(reader.options.at("filename").get<std::string>());
  seg.level0 = {seg.source->width(), seg.source->height(), seg.source->header().georef};
  add_seconds(reader, std::chrono::duration<double>(Clock::now() - t0).count());
  Level level = seg.level0;
  int li = 0;
  for (size_t i = first + 1; i < last; ++i) {
    const PipelineStage& st = stages[i];
    StageTiling tl = tiling_of(st);
    if (tl.halo_of) tl.halo = tl.halo_of(level.georef);
    if (tl.kind == TileKind::Global) {
      // Is the global stage's output written right away and nothing else follows? Then it writes
      // the final file itself (no temporary copy).
      // (Not a warp: it writes its input to the global stage's file first, and a warp's output
      // is a new grid; a failed warp must leave no output behind.)
      const bool direct = i + 2 == last && stages[i + 1].type == "write" && !tile::is_warp_stage(st);
      if (tile::is_warp_stage(st)) io_check_warp(st);
      std::string out;
      Metadata md;
      if (direct) {
        out = stages[i + 1].options.at("filename").get<std::string>();
        md = provenance(stages[i + 1]);
      } else {
        const fs::path ref = m_p.outputs().empty() ? fs::path(m_p.source()) : fs::path(m_p.outputs().front());
        out = (ref.parent_path() / fmt::format(".{}.tiles-{}.tif", ref.filename().string(), st.tag)).string();
        m_temporaries.push_back(out);
      }
      run_segment(seg, &st, out, md);
      if (direct) return;
      Segment next;
      next.read_tag = st.tag;
      next.stamp = st.tag;  // recomputed by every run from the same input: its name suffices
      next.source = std::make_shared<io::GdalWindowReader>(out);
      next.metadata = seg.metadata;
      if (tile::is_warp_stage(st)) {
        level = *m_warped;  // a new grid: GDAL's for the whole input
        for (const auto& [k, v] : m_warped_metadata) next.metadata[k] = v;
      }
      next.level0 = level;  // the level's own georef (metric cell size), not one recomputed from the file
      next.level0.georef.nodata = next.source->header().georef.nodata;
      next.level0.georef.vertical_units = next.source->header().georef.vertical_units;  // m2 after drainage
      seg = std::move(next);
      li = 0;
      continue;
    }
    seg.ops.push_back({&st, tl, li});
    if (tl.kind == TileKind::Window) {
      const int64_t x0 = st.options.at("x").get<int64_t>(), y0 = st.options.at("y").get<int64_t>();
      const int64_t w = st.options.at("width").is_null() ? level.w - x0 : st.options.at("width").get<int64_t>();
      const int64_t h = st.options.at("height").is_null() ? level.h - y0 : st.options.at("height").get<int64_t>();
      if (x0 < 0 || y0 < 0 || w < 1 || h < 1 || x0 + w > level.w || y0 + h > level.h)
        throw Error(st.tag,
                    fmt::format("window x {}..{}, y {}..{} does not fit in the {} x {} raster (pipeline stage {}, "
                                "tag '{}')",
                                x0, x0 + w - 1, y0, y0 + h - 1, level.w, level.h, st.where, st.tag));
      Georef g = georef_at(level.georef, int(x0), int(y0));
      if (g.has_geotransform) g.update_metric_cell_size(int(w), int(h));  // as crop: the window's centre latitude
      level = {int(w), int(h), g};
      ++li;
    } else if (tl.kind == TileKind::Local) {
      const int f = tl.down, u = tl.up;
      if (level.w < f || level.h < f)
        throw Error(st.tag, fmt::format("a {} x {} raster has no complete {} x {} block (pipeline stage {}, tag '{}')",
                                        level.w, level.h, f, f, st.where, st.tag));
      level = next_level(level, f, u);
      ++li;
    }
  }
  run_segment(seg, nullptr, "", {});
}

void TiledRun::run_segment(const Segment& seg, const PipelineStage* global, const std::string& global_out,
                           const Metadata& global_md) {
  // Levels of the segment.
  std::vector<Level> levels{seg.level0};
  int extra_halo = m_t.halo ? *m_t.halo : 0;
  int total_halo = 0;
  for (const Op& op : seg.ops) {
    const Level& l = levels.back();
    if (op.tiling.kind == TileKind::Window) {
      const auto& o = op.st->options;
      const int x0 = o.at("x").get<int>(), y0 = o.at("y").get<int>();
      const int w = o.at("width").is_null() ? l.w - x0 : o.at("width").get<int>();
      const int h = o.at("height").is_null() ? l.h - y0 : o.at("height").get<int>();
      Georef g = georef_at(l.georef, x0, y0);
      if (g.has_geotransform) g.update_metric_cell_size(w, h);
      levels.push_back({w, h, g});
    } else if (op.tiling.kind == TileKind::Local) {
      levels.push_back(next_level(l, op.tiling.down, op.tiling.up));
      total_halo += op.tiling.halo;
    }
  }
  const size_t nl = levels.size();
  const bool has_global = global != nullptr;
  const bool warp = has_global && tile::is_warp_stage(*global);
  // Else the global stage reads the source directly; a warp always reads the level as the tile
  // writer stores it (float32, NaN as the level's nodata), which is what the untiled warp sees.
  const bool to_temp = has_global && (!seg.ops.empty() || warp);
  // Memory: the windows of one tile (about 3 copies of a float cell per level: the window, the
  // extracted input, the stage's output) and the writers' buffers.
  // A level that amplify made finer holds up^2 cells per cell of the source.
  double per_cell = 4.0 * 2;
  for (size_t i = 0; i < levels.size(); ++i)  // a gradient level (after extract) holds two bands
    per_cell += (gradient_level(seg, int(i)) ? 24.0 : 12.0) *
                std::max(1.0, double(levels[i].w) * levels[i].h / (double(levels[0].w) * levels[0].h));
  double fixed = 0;
  if (has_global) {
    per_cell = std::max(per_cell, 4.0 + 4 + 1 + 4 + 4 + 8);  // fill: z, labels, closed, window, core, heap share
    // drainage: window, dir, donors, uint64 count and inflow, order, exit, core
    if (global->type == "drainage") per_cell = std::max(per_cell, 4.0 + 1 + 1 + 8 + 8 + 4 + 4 + 4);
    fixed = 0;  // the perimeter graph is added below once the tile size is known
  }
  int T = tile_size(seg, per_cell * (1 + 4.0 * (total_halo + extra_halo) / 256.0), fixed);
  if (has_global && !warp && m_t.memory_budget > 0) {
    // Perimeter cells (4 per tile side cell), each with its node, about four edges while the graph
    // is built (24 B each) and its adjacency: about 200 B per perimeter cell at the peak.
    const double graph = 4.0 * double(levels.back().w) * levels.back().h / T * 200.0;
    if (graph + per_cell * double(T) * T > 0.5 * double(m_t.memory_budget))
      throw UsageError("run",
                       fmt::format("--memory-budget {}: the tiled fill's perimeter graph ({} with {}-cell tiles) and a "
                                   "tile do not fit; use a larger --tile or budget",
                                   human_bytes(double(m_t.memory_budget)), human_bytes(graph), T));
  }

  // Writers of this segment, created at the first tile that reaches them.
  Writers writers;
  Journals journals;  // --resume
  std::unique_ptr<io::GeoTiffWindowWriter> temp_writer;
  std::map<const PipelineStage*, std::unique_ptr<tile::TileSink>> stage_sinks;  // sinks other than `write`
  const Level& W0 = levels[0];
  const int tx = (W0.w + T - 1) / T, ty = (W0.h + T - 1) / T;
  const Progress prog = progress(seg.ops.empty() ? (global ? global->tag : "tiles") : seg.ops.front().st->tag);
  StageData data;
  const Metadata no_provenance;
  // The window of its input level that a (non-sink) op needs for the window n of its output level.
  auto window_before = [&](const Op& op, const Win& n) -> Win {
    if (op.tiling.kind == TileKind::Window) {
      const int x0 = op.st->options.at("x").get<int>(), y0 = op.st->options.at("y").get<int>();
      return {n.x0 + x0, n.y0 + y0, n.x1 + x0, n.y1 + y0};
    }
    // Local: f x f blocks (downsample) or u x u cells per input cell (amplify), and the halo.
    const int f = op.tiling.down, u = op.tiling.up, h = op.tiling.halo + (op.tiling.halo > 0 ? extra_halo : 0);
    const int x0 = n.x0 / u, y0 = n.y0 / u, x1 = (n.x1 + u - 1) / u, y1 = (n.y1 + u - 1) / u;
    return intersect({x0 * f - h, y0 * f - h, x1 * f + h, y1 * f + h}, {0, 0, levels[op.level].w, levels[op.level].h});
  };
  // Prepass results (amplify's correlations), by op.
  std::map<const Op*, std::string> prepass;
  // Runs the (non-sink) op on data, which holds the window `have` of its input level, into the
  // window n of its output level.
  auto run_step = [&](const Op& op, StageData& d, Win& have, const Win& n) {
    const int l = op.level;
    if (op.tiling.kind == TileKind::Window) {
      const int x0 = op.st->options.at("x").get<int>(), y0 = op.st->options.at("y").get<int>();
      Heightfield part = extract(*d.height, have, {n.x0 + x0, n.y0 + y0, n.x1 + x0, n.y1 + y0}, levels[l].georef);
      part.georef = georef_at(levels[l + 1].georef, n.x0, n.y0);
      d.height = std::move(part);
      have = n;
      return;
    }
    const int f = op.tiling.down, u = op.tiling.up;
    const Win in = window_before(op, n);
    d.height = extract(*d.height, have, in, levels[l].georef);
    d.current = DataKind::Heightfield;
    if (auto it = prepass.find(&op); it != prepass.end()) {
      d.height->metadata["terracl:tile_window"] = fmt::format("{} {}", in.x0, in.y0);
      d.height->metadata["terracl:tile_prepass"] = it->second;
    }
    StageContext ctx{d, op.st->options, m_device, Progress{}, op.st->tag, no_provenance};
    try {
      op.st->info->run(ctx);
    } catch (const Cancelled&) {
      throw;
    } catch (const Error& e) {
      throw Error(e.stage(), fmt::format("{} (pipeline stage {}, tag '{}', tile {},{} {} x {})",
                                         std::string(e.what()).substr(e.stage().size() + 2), op.st->where, op.st->tag,
                                         in.x0, in.y0, in.w(), in.h()));
    }
    if (d.current == DataKind::Gradient) {  // extract: same grid, a gradient from here on
      d.gradient = extract_gradient_window(*d.gradient, in, n);
      d.gradient->georef = georef_at(levels[l + 1].georef, n.x0, n.y0);
      d.height.reset();
      have = n;
      return;
    }
    const Win out = {in.x0 / f * u, in.y0 / f * u, in.x0 / f * u + d.height->width, in.y0 / f * u + d.height->height};
    d.height = extract(*d.height, out, n, levels[l + 1].georef);
    have = n;
  };
  // The window w of level l, computed from the source through the ops before it.
  auto read_level = [&](int l, const Win& w) {
    std::vector<Win> need(nl);
    need[size_t(l)] = w;
    std::vector<const Op*> chain(nl, nullptr);
    for (const Op& o : seg.ops)
      if (o.tiling.kind != TileKind::Sink && o.level < l) chain[size_t(o.level)] = &o;
    for (int k = l - 1; k >= 0; --k) need[size_t(k)] = window_before(*chain[size_t(k)], need[size_t(k) + 1]);
    StageData d;
    Win have = need[0];
    d.height = seg.source->read(have.x0, have.y0, have.w(), have.h());
    d.height->georef = georef_at(levels[0].georef, have.x0, have.y0);
    drop_terracl_keys(d.height->metadata);
    for (int k = 0; k < l; ++k) run_step(*chain[size_t(k)], d, have, need[size_t(k) + 1]);
    return extract(*d.height, have, w, levels[size_t(l)].georef);
  };
  // Cores per level (forward), then the windows each level needs (backward), for every tile; tiles
  // that no writer needs (outside a crop) are dropped, so that progress counts real work.
  struct TilePlan {
    std::vector<Win> core, need;
  };
  std::vector<TilePlan> plans;
  for (int j = 0; j < ty && (!seg.ops.empty() || to_temp); ++j)
    for (int i = 0; i < tx; ++i) {
      std::vector<Win> core(nl), need(nl);
      core[0] = {i * T, j * T, std::min(W0.w, (i + 1) * T), std::min(W0.h, (j + 1) * T)};
      for (const Op& op : seg.ops) {
        const Win& c = core[op.level];
        const Level& out = levels[op.level + 1 < int(nl) ? op.level + 1 : op.level];
        if (op.tiling.kind == TileKind::Window) {
          const int x0 = op.st->options.at("x").get<int>(), y0 = op.st->options.at("y").get<int>();
          core[op.level + 1] = intersect({c.x0 - x0, c.y0 - y0, c.x1 - x0, c.y1 - y0}, {0, 0, out.w, out.h});
        } else if (op.tiling.kind == TileKind::Local) {
          const int f = op.tiling.down, u = op.tiling.up;  // tile corners are multiples of f: blocks never straddle tiles
          core[op.level + 1] = intersect({c.x0 / f * u, c.y0 / f * u, c.x1 / f * u, c.y1 / f * u}, {0, 0, out.w, out.h});
        }
      }
      for (int l = int(nl) - 1; l >= 0; --l) {
        for (const Op& op : seg.ops)
          if (op.level == l && op.tiling.kind == TileKind::Sink) {
            // A sink with a footprint (render) reads its halo around the core.
            const int h = op.tiling.halo;
            const Win c = core[l];
            need[l] = unite(need[l], h > 0 && !c.empty() ? intersect({c.x0 - h, c.y0 - h, c.x1 + h, c.y1 + h},
                                                                     {0, 0, levels[l].w, levels[l].h})
                                                         : c);
          }
        if (to_temp && l == int(nl) - 1) need[l] = unite(need[l], core[l]);
        if (l + 1 < int(nl) && !need[l + 1].empty()) {
          const Op* op = nullptr;
          for (const Op& o : seg.ops)
            if (o.level == l && o.tiling.kind != TileKind::Sink) op = &o;
          need[l] = unite(need[l], window_before(*op, need[l + 1]));
        }
      }
      if (!need[0].empty()) plans.push_back({std::move(core), std::move(need)});
    }
  // Prepasses (amplify's correlations): once, on the whole input level of their op, before any tile.
  for (const Op& op : seg.ops)
    if (op.tiling.prepass && !plans.empty()) {
      const auto t0 = Clock::now();
      const Level& L = levels[size_t(op.level)];
      prepass[&op] = op.tiling.prepass([&](int x, int y, int w, int h) { return read_level(op.level, {x, y, x + w, y + h}); },
                                       L.w, L.h);
      add_seconds(*op.st, std::chrono::duration<double>(Clock::now() - t0).count());
    }
  // --resume: tiles an interrupted run finished (segments feeding a global stage are recomputed).
  // Under mpirun rank 0 owns the journals and the partial files (it writes every output): it
  // decides which tiles are finished and tells the other ranks before the hand-out.
  const bool resumable = m_t.resume && !to_temp;
  std::vector<char> finished(plans.size(), 0);
  if (resumable) {
    if (tile::comm().rank() == 0) {
      std::vector<std::vector<Win>> cores;
      for (const auto& pl : plans) cores.push_back(pl.core);
      finished = prepare_resume(seg, levels, cores, T, writers, journals);
    }
    if (tile::comm().size() > 1) {
      tile::Bytes b(finished.begin(), finished.end());
      tile::comm().broadcast(b);
      if (b.size() != plans.size())
        fail("run", "internal: rank 0 resumes {} tiles, this rank planned {}", b.size(), plans.size());
      finished.assign(b.begin(), b.end());
    }
  }
  std::vector<std::pair<const PipelineStage*, uint64_t>> written;  // this tile's checksum per writer
  // A tile's results for its sinks are computed by the tile's rank and written by rank 0, in tile
  // order (tile_comm.hpp): one process does both, tile by tile.
  const tile::Comm& comm = tile::comm();
  std::map<const PipelineStage*, std::unique_ptr<tile::TileSink>> draw_sinks;  // ranks > 0: draw only
  auto sink_for = [&](const Op& op, const Metadata& tile_md) -> tile::TileSink& {
    auto& sink = comm.rank() == 0 ? stage_sinks[op.st] : draw_sinks[op.st];
    if (!sink) {
      Metadata md = tile_md;
      drop_terracl_keys(md);
      const Level& L = levels[op.level];
      sink = op.st->type == "metrics"
                 ? tile::make_metrics_sink(*op.st, L.w, L.h, L.georef, provenance(*op.st), comm.rank() == 0)
                 : tile::make_render_sink(*op.st, L.w, L.h, L.georef, md, provenance(*op.st), m_device, comm.rank() == 0);
    }
    return *sink;
  };
  auto core_floats = [](const Heightfield& h, const Win& have, const Win& c) {
    tile::Bytes b(size_t(c.w()) * c.h() * sizeof(float));
    for (int y = 0; y < c.h(); ++y)
      std::memcpy(&b[size_t(y) * c.w() * sizeof(float)], &h.z[size_t(c.y0 - have.y0 + y) * h.width + (c.x0 - have.x0)],
                  size_t(c.w()) * sizeof(float));
    return b;
  };
  auto compute = [&](size_t ti) {
    std::vector<SinkCall> calls;
    const std::vector<Win>& core = plans[ti].core;
    const std::vector<Win>& need = plans[ti].need;
    auto t0 = Clock::now();
    Win have = need[0];
    data = StageData{};
    data.height = seg.source->read(have.x0, have.y0, have.w(), have.h());
    data.height->georef = georef_at(levels[0].georef, have.x0, have.y0);
    drop_terracl_keys(data.height->metadata);
    for (const auto& [k, v] : seg.metadata) data.height->metadata[k] = v;
    m_seconds[seg.read_tag] += std::chrono::duration<double>(Clock::now() - t0).count();
    for (size_t oi = 0; oi < seg.ops.size(); ++oi) {
      const Op& op = seg.ops[oi];
      const int l = op.level;
      m_report.running = op.st->tag;
      stop_point(op.st->tag);
      t0 = Clock::now();
      if (op.tiling.kind == TileKind::Sink) {
        const Win& c = core[l];
        if (c.empty()) continue;
        if (op.st->type != "write") {
          const int h = op.tiling.halo;
          const Win in = intersect({c.x0 - h, c.y0 - h, c.x1 + h, c.y1 + h}, {0, 0, levels[l].w, levels[l].h});
          try {
            tile::TileSink& sink = sink_for(op, data.height->metadata);
            calls.push_back(
                {int(oi), 1, c, data.height->metadata,
                 sink.draw(extract(*data.height, have, in, levels[l].georef), in.x0, in.y0, c.x0, c.y0, c.w(), c.h())});
          } catch (const Error& e) {
            throw Error(e.stage(), fmt::format("{} (pipeline stage {}, tag '{}', tile {},{} {} x {})",
                                               std::string(e.what()).substr(e.stage().size() + 2), op.st->where,
                                               op.st->tag, in.x0, in.y0, in.w(), in.h()));
          }
        } else if (data.current == DataKind::Gradient) {
          // gx then gy; the mean elevation (the whole raster's, from the prepass) as the EXR stores it.
          const GradientField& g = *data.gradient;
          Heightfield band(g.width, g.height);
          band.z = g.gx;
          tile::Bytes payload = core_floats(band, have, c);
          band.z = g.gy;
          const tile::Bytes gy = core_floats(band, have, c);
          payload.insert(payload.end(), gy.begin(), gy.end());
          Metadata md = g.metadata;
          md["terracl:mean_elevation"] = fmt::format("{:.17g}", g.mean_elevation);
          calls.push_back({int(oi), 2, c, std::move(md), std::move(payload)});
        } else {
          // Compressed here, by the tile's rank: rank 0 only appends the blocks (docs/scale.md).
          const Level& L = levels[l];
          calls.push_back({int(oi), 1, c, data.height->metadata,
                           io::GeoTiffWindowWriter::encode(L.w, L.h, L.georef.nodata, c.x0, c.y0, *data.height,
                                                           c.x0 - have.x0, c.y0 - have.y0, c.w(), c.h(), !resumable)});
        }
      } else {
        const Win& n = need[l + 1];
        if (n.empty()) break;
        run_step(op, data, have, n);
      }
      add_seconds(*op.st, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    if (to_temp && !core[nl - 1].empty()) {
      const Win& c = core[nl - 1];
      const Level& L = levels[nl - 1];
      calls.push_back({-1, 1, c, {},
                       io::GeoTiffWindowWriter::encode(L.w, L.h, L.georef.nodata, c.x0, c.y0, *data.height,
                                                       c.x0 - have.x0, c.y0 - have.y0, c.w(), c.h())});
    }
    return calls;
  };
  auto apply = [&](size_t ti, const std::vector<SinkCall>& calls) {
    written.clear();
    for (const SinkCall& call : calls) {
      const Win& c = call.core;
      // A stop between two outputs' windows: nothing of this tile is journaled (a rerun redoes it).
      stop_point(call.op < 0 ? std::string("tiles") : seg.ops[size_t(call.op)].st->tag);
      auto t0 = Clock::now();
      if (call.op < 0) {
        if (!temp_writer) {
          const Level& L = levels[nl - 1];
          temp_writer = std::make_unique<io::GeoTiffWindowWriter>(global_out, L.w, L.h, L.georef, Metadata{});
        }
        temp_writer->put(call.payload);
        continue;
      }
      const Op& op = seg.ops[size_t(call.op)];
      if (op.st->type != "write") {
        sink_for(op, call.md).put(call.payload, c.x0, c.y0, c.w(), c.h());
      } else {
        auto& wr = writers[op.st];
        const bool gradient = call.bands == 2;
        if (!wr) {
          Metadata md = call.md;
          drop_terracl_keys(md);
          for (const auto& [k, v] : provenance(*op.st)) md[k] = v;
          const std::string f = op.st->options.at("filename").get<std::string>();
          const Level& L = levels[op.level];
          Georef g = L.georef;
          if (gradient) {  // as the untiled write of a gradient to .tif (gradient_tiff.cpp)
            for (const char* k : {"terracl:gradient", "terracl:mean_elevation"})
              if (auto it = call.md.find(k); it != call.md.end()) md[k] = it->second;
            md = io::gradient_tiff_metadata(md, NAN, g.nodata);
            g = io::gradient_tiff_georef(g);
          }
          wr = std::make_unique<io::GeoTiffWindowWriter>(f, L.w, L.h, g, md,
                                                         resumable ? tile::partial_path_for(f) : std::string(),
                                                         call.bands);
        }
        if (gradient) {
          const uint64_t sx = wr->write(c.x0, c.y0, floats_to_core(call.payload, c.w(), c.h(), 2, 0), 0, 0, c.w(), c.h(), 1);
          const uint64_t sy = wr->write(c.x0, c.y0, floats_to_core(call.payload, c.w(), c.h(), 2, 1), 0, 0, c.w(), c.h(), 2);
          written.emplace_back(op.st, combine_checksums(sx, sy));
        } else {
          written.emplace_back(op.st, wr->put(call.payload));
        }
      }
      add_seconds(*op.st, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    // --resume: the tile's blocks reach the partial file before the journal names the tile, and
    // only a tile whose every window was written is named.
    stop_point("tiles");
    for (const auto& [st, sum] : written)
      if (auto j = journals.find(st); j != journals.end()) {
        writers.at(st)->flush();
        j->second->record(ti, sum);
      }
    ++m_counts.run;
    if (m_kill_after && m_counts.run == m_kill_after) ::kill(::getpid(), SIGKILL);
    report_progress(prog, "tiles", double(ti + 1) / plans.size(), fmt::format("tile {}/{}", ti + 1, plans.size()));
  };
  if (comm.size() == 1) {
    for (size_t ti = 0; ti < plans.size(); ++ti) {
      if (finished[ti]) {
        ++m_counts.skipped;
        report_progress(prog, "tiles", double(ti + 1) / plans.size(),
                        fmt::format("tile {}/{} (finished before)", ti + 1, plans.size()));
        continue;
      }
      apply(ti, compute(ti));
    }
  } else {
    // The tiles left to run go round-robin over the ranks (finished ones are not handed out).
    std::vector<size_t> todo;
    for (size_t ti = 0; ti < plans.size(); ++ti)
      if (!finished[ti]) todo.push_back(ti);
    if (comm.rank() == 0) m_counts.skipped += plans.size() - todo.size();
    tile::ordered_tiles(
        comm, todo.size(), [&](size_t k) { return pack_calls(compute(todo[k])); },
        [&](size_t k, const tile::Bytes& b) { apply(todo[k], unpack_calls(b)); });
  }
  for (auto& [st, wr] : writers) {
    auto t0 = Clock::now();
    wr->commit();
    if (auto j = journals.find(st); j != journals.end()) j->second->remove();
    add_seconds(*st, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  for (auto& [st, sink] : stage_sinks) {
    auto t0 = Clock::now();
    sink->commit();
    add_seconds(*st, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  if (temp_writer) temp_writer->commit();
  if (!global) return;
  comm.barrier();  // every rank reads the temporary rank 0 just wrote

  // The global stage, from the segment's last level (a temporary file or the source) to its output.
  m_report.running = global->tag;
  auto t0 = Clock::now();
  // From a temporary file, the result goes to a second one that then replaces it (and becomes the
  // next segment's source).
  const Level& L = levels[nl - 1];
  const std::string out_path = to_temp ? global_out + ".filled.tif" : global_out;
  Metadata md = global_md;
  if (warp) {
    // Rank 0 warps; every rank needs the output grid for the next segment.
    const Heightfield hdr =
        tile::warp_tiles(*global, global_out, L.georef, out_path, T, md, comm.rank() == 0, progress(global->tag));
    m_warped = Level{hdr.width, hdr.height, hdr.georef};
    m_warped_metadata.clear();
    for (const auto& [k, v] : hdr.metadata)
      if (k.rfind("engine:", 0) == 0) m_warped_metadata[k] = v;
    if (comm.rank() == 0 && to_temp) {
      std::error_code ec;
      fs::rename(out_path, global_out, ec);
      if (ec) fail("run", "cannot rename {} to {}: {}", out_path, global_out, ec.message());
    }
    comm.barrier();
    add_seconds(*global, std::chrono::duration<double>(Clock::now() - t0).count());
    return;
  }
  std::shared_ptr<io::GdalWindowReader> in = to_temp ? std::make_shared<io::GdalWindowReader>(global_out) : seg.source;
  const bool drainage = global->type == "drainage";
  Georef out_georef = L.georef;
  if (drainage) {  // as run_drainage labels its output
    const bool cells = global->options.value("units", std::string("m2")) == "cells";
    out_georef.vertical_units = cells ? "cells" : "m2";
    md["terracl:quantity"] = "D8 drainage area";
  }
  // Under MPI every rank floods its tiles; rank 0 gathers the perimeters, solves the graph and
  // writes every tile (the tiled algorithms use tile::comm()).
  std::unique_ptr<io::GeoTiffWindowWriter> out;
  if (comm.rank() == 0) out = std::make_unique<io::GeoTiffWindowWriter>(out_path, L.w, L.h, out_georef, md);
  auto read = [&](int x, int y, int w, int h) { return in->read(x, y, w, h); };
  // Each tile's rank compresses its core's blocks; rank 0 appends them (docs/scale.md, "MPI speed-up").
  const analysis::EncodingWindowWriter write{
      [&](int x, int y, const Heightfield& core) {
        return io::GeoTiffWindowWriter::encode(L.w, L.h, out_georef.nodata, x, y, core, 0, 0, core.width, core.height);
      },
      [&](int, int, const std::vector<uint8_t>& encoded) { out->put(encoded); }};
  if (drainage) {
    const double cx = L.georef.cell_x, cy = L.georef.cell_y;
    const double scale = out_georef.vertical_units == "cells" ? 1.0 : cx * cy;
    analysis::d8_accumulation_tiled(L.w, L.h, T, cx, cy, scale, read, write, progress(global->tag));
  } else {
    analysis::priority_flood_fill_tiled(L.w, L.h, T, read, write, progress(global->tag));
  }
  in.reset();
  if (out) {
    out->commit();
    if (to_temp) {
      std::error_code ec;
      fs::rename(out_path, global_out, ec);
      if (ec) fail("run", "cannot rename {} to {}: {}", out_path, global_out, ec.message());
    }
  }
  comm.barrier();  // the next segment reads what rank 0 wrote
  add_seconds(*global, std::chrono::duration<double>(Clock::now() - t0).count());
}

}  // namespace

void run_tiled(const Pipeline& p, const TileOptions& t, const RunOptions& o, RunReport& report, TileCounts* tiles) {
  const auto t_start = Clock::now();
  report = RunReport{};
  TiledRun run(p, t, o, report);
  run.run();
  if (tiles) *tiles = run.m_counts;
  if (o.write_resolved && tile::comm().rank() == 0) {
    report.resolved_path = p.resolved_path();
    const fs::path dir = fs::path(report.resolved_path).parent_path();
    if (!dir.empty()) fs::create_directories(dir);
    write_text_file_atomic(report.resolved_path, p.resolved_text());
  }
  report.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
}

}  // namespace terracl
