// SPDX-License-Identifier: Apache-2.0
// Tiled `metrics` (docs/scale.md, "Tiled metrics"): a sink with a 3x3 footprint that gathers the
// report's local statistics tile by tile into exact accumulators (analysis/local_metrics.hpp) and
// spills the slopes to a temporary file, from which the quantiles are selected exactly in two
// passes (a histogram of the floats' upper 16 bits, then of the lower 16 bits of the bins holding
// the wanted ranks): bounded memory, and the untiled report's numbers bit for bit. The global
// figures (spectrum, fill, breach, drainage) are left out with a note.
#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include "analysis/local_metrics.hpp"
#include "tile/tile_comm.hpp"
#include "tile/tile_sinks.hpp"

namespace terracl::tile {
namespace {

namespace fs = std::filesystem;
using analysis::LocalMetrics;

const char* kTiledNote =
    "tiled run: spectral_slope, fill, breach and drainage need the whole raster and are left out; run metrics "
    "untiled (on the output or a downsample of it) for them";

class MetricsSink : public TileSink {
 public:
  MetricsSink(const PipelineStage& st, int w, int h, const Georef& level, const Metadata& provenance, bool open)
      : m_tag(st.tag), m_w(w), m_h(h), m_level(level), m_provenance(provenance) {
    const json& o = st.options;
    if (!open || !o.contains("json") || o.at("json").is_null()) return;
    m_json = o.at("json").get<std::string>();
    const fs::path p(m_json);
    m_spill = (p.parent_path() / fmt::format(".{}.slopes-{}.tmp", p.filename().string(), ::getpid())).string();
    m_file = std::fopen(m_spill.c_str(), "w+b");
    if (!m_file) fail(m_tag, "cannot create the temporary slope file {}: {}", m_spill, std::strerror(errno));
  }
  ~MetricsSink() override {
    if (m_file) std::fclose(m_file);
    if (!m_spill.empty()) {
      std::error_code ec;
      fs::remove(m_spill, ec);
    }
  }

  std::vector<uint8_t> draw(const Heightfield& window, int wx, int wy, int cx, int cy, int cw, int ch) override {
    LocalMetrics m;
    std::vector<float> slopes;
    slopes.reserve(size_t(cw) * ch);
    analysis::accumulate_local_metrics(window, wx, wy, cx, cy, cw, ch, m_w, m_h, m, slopes);
    ByteWriter w;
    w.put(m).put_vector(slopes);
    return std::move(w.bytes());
  }

  void put(const std::vector<uint8_t>& drawn, int, int, int, int) override {
    ByteReader r(drawn);
    const LocalMetrics m = r.get<LocalMetrics>();
    m_total.merge(m);
    const std::vector<float> slopes = r.get_vector<float>();
    if (m_file && !slopes.empty() && std::fwrite(slopes.data(), sizeof(float), slopes.size(), m_file) != slopes.size())
      fail(m_tag, "writing the temporary slope file {} failed: {}", m_spill, std::strerror(errno));
  }

  void commit() override {
    if (!m_file) return;  // no report asked for
    if (m_total.valid == 0) fail(m_tag, "the heightfield has no valid cell");
    const size_t n = m_total.valid;
    std::array<double, 5> q{};
    std::map<size_t, float> at;  // rank -> value
    for (double f : analysis::kMetricQuantiles) {
      const auto [a, b] = analysis::quantile_ranks(n, f);
      at[a] = at[b] = 0;
    }
    select(at);
    for (size_t i = 0; i < q.size(); ++i) {
      const double f = analysis::kMetricQuantiles[i];
      const auto [a, b] = analysis::quantile_ranks(n, f);
      q[i] = analysis::quantile_between(n, f, at.at(a), at.at(b));
    }
    json j = analysis::local_metrics_json(m_total, q, m_w, m_h, m_level.cell_x, m_level.cell_y);
    j["tiled"] = kTiledNote;
    j["provenance"] = m_provenance;
    write_text_file_atomic(m_json, j.dump(2) + "\n");
  }

 private:
  // Streams the spilled slopes (non-negative floats: their bits sort as their values).
  template <class F>
  void scan(F&& f) {
    std::rewind(m_file);
    std::vector<uint32_t> buf(1 << 20);
    size_t got;
    while ((got = std::fread(buf.data(), sizeof(uint32_t), buf.size(), m_file)) > 0)
      for (size_t i = 0; i < got; ++i) f(buf[i]);
    if (std::ferror(m_file)) fail(m_tag, "reading the temporary slope file {} failed", m_spill);
  }

  // The values at the ranks (keys of `at`) of the spilled slopes, exactly.
  void select(std::map<size_t, float>& at) {
    std::fflush(m_file);
    std::vector<uint64_t> hi(1 << 16, 0);
    scan([&](uint32_t b) { ++hi[b >> 16]; });
    std::map<uint32_t, std::vector<uint64_t>> lo;  // bin -> counts of the lower 16 bits
    std::map<size_t, std::pair<uint32_t, uint64_t>> where;  // rank -> (bin, rank inside it)
    for (auto& [rank, v] : at) {
      uint64_t before = 0;
      uint32_t bin = 0;
      while (before + hi[bin] <= rank) before += hi[bin++];
      where[rank] = {bin, rank - before};
      lo[bin].assign(1 << 16, 0);
    }
    scan([&](uint32_t b) {
      if (auto it = lo.find(b >> 16); it != lo.end()) ++it->second[b & 0xffff];
    });
    for (auto& [rank, v] : at) {
      const auto [bin, r] = where.at(rank);
      const std::vector<uint64_t>& c = lo.at(bin);
      uint64_t before = 0;
      uint32_t low = 0;
      while (before + c[low] <= r) before += c[low++];
      const uint32_t bits = (bin << 16) | low;
      std::memcpy(&v, &bits, sizeof v);
    }
  }

  std::string m_tag;
  int m_w, m_h;
  Georef m_level;
  Metadata m_provenance;
  std::string m_json, m_spill;
  std::FILE* m_file = nullptr;
  LocalMetrics m_total;
};

}  // namespace

std::unique_ptr<TileSink> make_metrics_sink(const PipelineStage& stage, int width, int height, const Georef& level,
                                            const Metadata& provenance, bool open) {
  return std::make_unique<MetricsSink>(stage, width, height, level, provenance, open);
}

}  // namespace terracl::tile
