// SPDX-License-Identifier: Apache-2.0
// Helpers of a tiled run: windows, the sink calls that travel between ranks, provenance keys.
#include "tile/tiled_run.hpp"

#include "io/io_common.hpp"

namespace terracl::tiled {

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
Heightfield floats_to_core(const tile::Bytes& b, int w, int h, int bands, int band) {
  Heightfield core(w, h);
  const size_t n = core.z.size() * sizeof(float);
  if (b.size() != n * size_t(bands))
    throw Error("tile", fmt::format("internal: a {} x {} x {} core arrived as {} bytes", w, h, bands, b.size()));
  std::memcpy(core.z.data(), b.data() + n * size_t(band), n);
  return core;
}

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

void drop_terracl_keys(Metadata& md) { io::drop_terracl_keys(md); }

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
}  // namespace terracl::tiled
