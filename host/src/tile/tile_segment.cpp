// SPDX-License-Identifier: Apache-2.0
// One segment of a tiled run, tile by tile: the windows every level needs, found backwards from
// the tile's core at each writer; the read; each stage on its window; each sink's core; then the
// segment's global stage, if any, from the segment's output into the next segment's source.
#include "tile/tiled_run.hpp"

namespace terracl::tiled {

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
      if (g.has_geotransform && g.geographic) g.update_metric_cell_size(w, h);  // as crop
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
  // The global stage's input gets a file of its own: global_out may be the pipeline's final
  // output, which must receive the finished result or nothing (a failed tiled drainage once left
  // the elevations it read under the output's name, over an earlier good file).
  std::string global_in;
  if (to_temp) {
    const fs::path o(global_out);
    global_in = (o.parent_path() / fmt::format(".{}.input.tif", o.filename().string())).string();
    m_temporaries.push_back(global_in);
  }
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
  // Perimeter cells (4 per tile side cell), each with its node, about four edges while the graph
  // is built (24 B each) and its adjacency: about 200 B per perimeter cell at the peak.
  const bool has_graph = has_global && !warp && m_t.memory_budget > 0;
  auto graph_bytes = [&](int t) { return 4.0 * double(levels.back().w) * levels.back().h / t * 200.0; };
  int T = tile_size(seg, per_cell * (1 + 4.0 * (total_halo + extra_halo) / 256.0), fixed,
                    has_graph ? std::function<double(int)>(graph_bytes) : std::function<double(int)>());
  if (has_graph) {
    const double graph = graph_bytes(T);
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
          // In the unit the writer below will have (feet read: feet written), on any rank.
          calls.push_back({int(oi), 1, c, data.height->metadata,
                           io::GeoTiffWindowWriter::encode(
                               L.w, L.h, L.georef.nodata, c.x0, c.y0, *data.height, c.x0 - have.x0, c.y0 - have.y0,
                               c.w(), c.h(), !resumable, io::written_metres_per_unit(L.georef, data.height->metadata))});
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
          temp_writer = std::make_unique<io::GeoTiffWindowWriter>(global_in, L.w, L.h, L.georef, Metadata{});
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
  // The writers below commit their output under global_out only once it is complete.
  const Level& L = levels[nl - 1];
  const std::string& in_path = to_temp ? global_in : global_out;
  const std::string& out_path = global_out;
  Metadata md = global_md;
  if (warp) {
    // Rank 0 warps; every rank needs the output grid for the next segment.
    const Heightfield hdr =
        tile::warp_tiles(*global, in_path, L.georef, out_path, T, md, comm.rank() == 0, progress(global->tag));
    m_warped = Level{hdr.width, hdr.height, hdr.georef};
    m_warped_metadata.clear();
    for (const auto& [k, v] : hdr.metadata)
      if (k.rfind("engine:", 0) == 0) m_warped_metadata[k] = v;
    comm.barrier();
    add_seconds(*global, std::chrono::duration<double>(Clock::now() - t0).count());
    return;
  }
  std::shared_ptr<io::GdalWindowReader> in = to_temp ? std::make_shared<io::GdalWindowReader>(global_in) : seg.source;
  const bool drainage = global->type == "drainage";
  Georef out_georef = L.georef;
  if (drainage && global->options.value("product", std::string("area")) != "area")
    throw UsageError("drainage", "product " + global->options.value("product", std::string()) +
                                     " (a D8 pointer raster) runs untiled only; the tiled drainage writes the area");
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
        return io::GeoTiffWindowWriter::encode(L.w, L.h, out_georef.nodata, x, y, core, 0, 0, core.width, core.height,
                                               true, io::written_metres_per_unit(out_georef, md));
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
  if (out) out->commit();
  comm.barrier();  // the next segment reads what rank 0 wrote
  add_seconds(*global, std::chrono::duration<double>(Clock::now() - t0).count());
}


}  // namespace terracl::tiled
