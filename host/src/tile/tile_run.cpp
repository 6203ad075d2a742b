// SPDX-License-Identifier: Apache-2.0
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
#include "tile/tiled_run.hpp"

#include "io/gdal_common.hpp"

namespace terracl {
namespace fs = std::filesystem;

namespace tiled {

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

int TiledRun::tile_size(const Segment& seg, double bytes_per_core_cell, double fixed_bytes,
                        const std::function<double(int)>& per_tile_bytes) const {
  int align = 1;
  for (const Op& op : seg.ops)
    if (op.tiling.kind == TileKind::Local) align *= op.tiling.down;
  auto fits = [&](int T) {
    return fixed_bytes + bytes_per_core_cell * double(T) * T + (per_tile_bytes ? per_tile_bytes(T) : 0.0);
  };
  int T = m_t.tile;
  if (T <= 0) {
    T = 2048;
    if (m_t.memory_budget > 0) {
      // The largest multiple of 256 whose tile fits in the half of the budget GDAL's cache leaves
      // (every size is tried: with a perimeter graph the need is smallest at a middle size).
      T = 256;
      for (int t = 512; t <= 16384; t += 256)
        if (fits(t) <= 0.5 * double(m_t.memory_budget)) T = t;
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
  // GDAL's block cache defaults to 5 % of RAM: bound it by the budget (after init_gdal, which
  // sets terracl's own default).
  io::init_gdal();
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
      // Feet read, feet written (io::written_vertical_unit), as the untiled write; a temporary in
      // feet reads back in metres with the unit named, for the next segment's writers.
      if (seg.source) {
        const Metadata& read = seg.source->header().metadata;
        if (auto it = read.find("terracl:source_vertical_units"); it != read.end()) md.insert(*it);
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
      if (g.has_geotransform && g.geographic) g.update_metric_cell_size(int(w), int(h));  // as crop: the window's centre latitude
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

}  // namespace tiled

using tiled::Clock;
using tiled::TiledRun;

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
