// SPDX-License-Identifier: Apache-2.0
#include "authoring/landform_detail.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cpl_vsi.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <optional>
#include <map>
#include <memory>
#include <mutex>

namespace terracl::detail {
const std::map<std::string, std::string>& embedded_styles();  // generated from data/styles/
}

namespace terracl::edit {
namespace {

// The "local" style learns from a window of the base around the stroke, snapped to a lattice of
// half its side so that strokes near each other share one dictionary.
constexpr int kLocalWindow = 512;

// A bundled exemplar: an ESRI ASCII grid embedded in the library, read by GDAL from memory.
Heightfield bundled_exemplar(const std::string& name) {
  const auto& files = detail::embedded_styles();
  const auto it = files.find(name + ".asc");
  if (it == files.end()) fail("edit", "no bundled style '{}' (bundled: alpine, eroded_hills, dissected_plateau)", name);
  const std::string path = fmt::format("/vsimem/terracl_style_{}.asc", name);
  std::vector<GByte> bytes(it->second.begin(), it->second.end());
  VSILFILE* f = VSIFileFromMemBuffer(path.c_str(), bytes.data(), vsi_l_offset(bytes.size()), FALSE);
  if (!f) fail("edit", "style '{}': GDAL could not map its exemplar in memory", name);
  VSIFCloseL(f);
  Heightfield h;
  try {
    h = read_heightfield(path);
  } catch (...) {
    VSIUnlink(path.c_str());
    throw;
  }
  VSIUnlink(path.c_str());
  return h;
}

// Every training patch an atom and the gain calibrated on held-out folds: ~0.2 s for a 256^2
// exemplar on 2 cores (the studio's first stroke of a style pays it once per process).
Dictionary learn_style(const Heightfield& exemplar) {
  LearnOptions lo;
  lo.method = "complete";
  lo.max_patches = 4000;
  lo.faithful_radius = 0;
  return learn_dictionary({exemplar}, lo);
}

uint64_t fnv1a(const void* data, size_t bytes, uint64_t h = 1469598103934665603ull) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

// A style's dictionary and the detail blend's correlations measured once on its exemplar's block
// means: every stroke then blends with the style's own figures (a stroke's box is too small to
// measure them on, and measuring them cost more than the synthesis).
struct Style {
  Dictionary dict;
  std::vector<float> correlations;
};

AmplifyOptions style_options(const Dictionary& d, uint32_t seed, double strength) {
  AmplifyOptions o;
  o.factor = d.factor;
  o.seed = seed;
  o.detail_gain = float(d.detail_gain * strength);
  // FLANN's randomized kd-trees (seeded: the same atoms every run): a third of a stroke's detail
  // time against the exact scan of the 4000 atoms, with the same texture figures.
  o.search = "flann";
  return o;
}

// At most this many dictionaries stay cached (about 4 MB each); the least recently used goes first.
constexpr size_t kStyleCache = 32;

std::shared_ptr<const Style> cached(const std::string& key, const std::function<Heightfield()>& exemplar) {
  static std::mutex mutex;
  static std::map<std::string, std::pair<std::shared_ptr<const Style>, uint64_t>> cache;
  static uint64_t clock = 0;
  std::lock_guard<std::mutex> lock(mutex);
  const auto it = cache.find(key);
  if (it != cache.end()) {
    it->second.second = ++clock;
    return it->second.first;
  }
  const Heightfield ex = exemplar();
  auto st = std::make_shared<Style>();
  st->dict = learn_style(ex);
  const Heightfield low = block_mean(ex, st->dict.factor);
  const AmplifyWindowReader read = [&](int x, int y, int w, int h) {
    Heightfield win(w, h);
    win.georef.cell_x = low.georef.cell_x, win.georef.cell_y = low.georef.cell_y;
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) win.at(c, r) = low.at(x + c, y + r);
    return win;
  };
  st->correlations = amplify_correlations(read, low.width, low.height, st->dict, style_options(st->dict, 1, 1));
  if (cache.size() >= kStyleCache)
    cache.erase(std::min_element(cache.begin(), cache.end(), [](const auto& a, const auto& b) { return a.second.second < b.second.second; }));
  cache.emplace(key, std::make_pair(st, ++clock));
  return st;
}

// The dictionary of the local window of `base` with its corner at (x0, y0).
std::shared_ptr<const Style> local_dictionary(const Heightfield& base, int x0, int y0, int side) {
  Heightfield w(side, side);
  w.georef.cell_x = base.georef.cell_x, w.georef.cell_y = base.georef.cell_y;
  for (int y = 0; y < side; ++y) std::memcpy(&w.at(0, y), base.z.data() + size_t(y0 + y) * base.width + x0, sizeof(float) * size_t(side));
  const uint64_t h = fnv1a(w.z.data(), w.z.size() * sizeof(float), fnv1a(&w.georef.cell_x, sizeof(double)));
  return cached(fmt::format("local:{:016x}:{}", h, side), [&] { return w; });
}

// The corner of the local window a stroke around (cx, cy) uses.
std::pair<int, int> local_window(const Heightfield& base, int cx, int cy, int side) {
  const int half = std::max(1, side / 2);
  return {std::clamp((cx - half) / half * half, 0, base.width - side), std::clamp((cy - half) / half * half, 0, base.height - side)};
}

// The dictionary of `style` for a stroke around cell (cx, cy) of `base` (the start terrain);
// nullptr when "local" has no base.
std::shared_ptr<const Style> style_dictionary(const Heightfield* base, const std::string& style, int cx, int cy) {
  if (style != "local") return cached("bundled:" + style, [&] { return bundled_exemplar(style); });
  if (!base) return nullptr;
  const int side = std::min({kLocalWindow, base->width, base->height});
  const auto [x0, y0] = local_window(*base, cx, cy, side);
  return local_dictionary(*base, x0, y0, side);
}

// `t` (a box of the terrain, cells of `g`) with its relief finer than the dictionary's factor
// replaced by detail synthesised from its block means. The dictionary's shapes are borrowed at the
// grid's scale: elevations scaled by the cell ratio keep every slope (as the amplify operation).
Heightfield dictionary_detail(const Heightfield& t, const Style& st, const Grid& g, uint32_t seed, double strength) {
  const Dictionary& d = st.dict;
  const int f = d.factor;
  const int W = (t.width + f - 1) / f * f, H = (t.height + f - 1) / f * f;
  const double k = std::sqrt((d.cell_x / g.cell_x) * (d.cell_y / g.cell_y));
  Heightfield p(W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) p.at(x, y) = float(k * t.at(std::min(x, t.width - 1), std::min(y, t.height - 1)));
  Heightfield low = block_mean(p, f);
  low.georef = Georef();
  low.georef.cell_x = d.cell_x * f, low.georef.cell_y = d.cell_y * f;
  const Heightfield up = amplify_window(low, 0, 0, d, style_options(d, seed, strength), st.correlations);
  Heightfield out(t.width, t.height);
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) out.at(x, y) = float(up.at(x, y) / k);
  return out;
}

// Per-cell weights of the styles over `box`: the stroke's own style, or ("auto") the painted
// regions over the default one, later regions covering earlier ones.
std::map<std::string, std::vector<float>> style_mix(const EditState& s, const Box& box, const DetailSpec& d) {
  std::map<std::string, std::vector<float>> mix;
  const size_t n = size_t(box.w) * box.h;
  if (d.style != "auto") {
    mix[d.style].assign(n, 1.f);
    return mix;
  }
  mix[s.start_terrain() ? "local" : d.fallback].assign(n, 1.f);
  for (const auto& layer : s.styles()) {
    std::vector<float> wl(n, 0.f);
    bool any = false;
    for (int y = 0; y < box.h; ++y)
      for (int x = 0; x < box.w; ++x) {
        const float v = float(layer.region.weight(box.x0 + x, box.y0 + y));
        wl[size_t(y) * box.w + x] = v, any = any || v > 0;
      }
    if (!any) continue;
    for (auto& [name, w] : mix)
      for (size_t i = 0; i < n; ++i) w[i] *= 1.f - wl[i];
    auto& mine = mix[layer.style];
    if (mine.empty()) mine.assign(n, 0.f);
    for (size_t i = 0; i < n; ++i) mine[i] += wl[i];
  }
  return mix;
}

// The terrain of `box`: the estimate plus `change` (0 where it has none).
Heightfield box_terrain(EditState& s, const Box& box, const ShapeRaster* change) {
  const Heightfield& est = terrain_estimate(s);
  Heightfield t(box.w, box.h);
  for (int y = 0; y < box.h; ++y)
    for (int x = 0; x < box.w; ++x) {
      const int gx = box.x0 + x, gy = box.y0 + y;
      t.at(x, y) = est.at(gx, gy) + (change && change->contains(gx, gy) ? change->at(gx, gy) : 0.f);
    }
  return t;
}

// The detail terrain of `box` mixed over the styles; nullopt when no style has a dictionary.
std::optional<Heightfield> mixed_detail(EditState& s, const Heightfield& t, const Box& box,
                                        const std::map<std::string, std::vector<float>>& mix, uint32_t seed, double strength) {
  std::optional<Heightfield> out;
  for (const auto& [name, w] : mix) {
    if (*std::max_element(w.begin(), w.end()) <= 1e-3f) continue;
    const auto dict = style_dictionary(s.start_terrain().get(), name, box.x0 + box.w / 2, box.y0 + box.h / 2);
    if (!dict) continue;
    const Heightfield u = dictionary_detail(t, *dict, s.grid(), seed, strength);
    if (!out) out = Heightfield(t.width, t.height, 0.f);
    for (size_t i = 0; i < u.z.size(); ++i) out->z[i] += w[i] * (u.z[i] - t.z[i]);
  }
  if (out)
    for (size_t i = 0; i < out->z.size(); ++i) out->z[i] += t.z[i];
  return out;
}

Box grown(const Box& b, int cells, const Grid& g) {
  Box o;
  o.x0 = std::max(0, b.x0 - cells), o.y0 = std::max(0, b.y0 - cells);
  o.w = std::min(g.width, b.x0 + b.w + cells) - o.x0, o.h = std::min(g.height, b.y0 + b.h + cells) - o.y0;
  return o;
}

// Distance (metres) from (x, y) to the polyline.
double distance_to(const std::vector<Vec2>& line, double x, double y) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < line.size(); ++i) {
    const Vec2 a = line[i], b = line[i + 1 < line.size() ? i + 1 : i];
    const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
    const double t = l2 > 0 ? std::clamp(((x - a.x) * ux + (y - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
    best = std::min(best, std::hypot(x - a.x - t * ux, y - a.y - t * uy));
  }
  return best;
}

}  // namespace

size_t warm_style(const std::string& style, const Heightfield* base, const std::function<bool()>& stop) {
  if (style != "local") return style_dictionary(nullptr, style, 0, 0) ? 1 : 0;
  if (!base) return 0;
  // Every window a stroke can land in (their corners lie on a lattice of half a window), the
  // nearest to the centre first: a stroke anywhere on a 1025^2 base finds its dictionary ready.
  const int side = std::min({kLocalWindow, base->width, base->height}), half = std::max(1, side / 2);
  std::vector<std::pair<int, int>> corners;
  for (int cy = 0; cy < base->height + half; cy += half)
    for (int cx = 0; cx < base->width + half; cx += half) {
      const auto c = local_window(*base, std::min(cx, base->width - 1), std::min(cy, base->height - 1), side);
      if (std::find(corners.begin(), corners.end(), c) == corners.end()) corners.push_back(c);
    }
  const auto dist = [&](const std::pair<int, int>& c) {
    return std::hypot(c.first + 0.5 * side - 0.5 * base->width, c.second + 0.5 * side - 0.5 * base->height);
  };
  std::stable_sort(corners.begin(), corners.end(), [&](const auto& a, const auto& b) { return dist(a) < dist(b); });
  size_t ready = 0;
  for (const auto& [x0, y0] : corners) {
    if (ready == kLocalWarmWindows || (stop && stop())) break;
    if (local_dictionary(*base, x0, y0, side)) ++ready;
  }
  return ready;
}

bool add_real_detail(EditState& s, ShapeRaster& change, const DetailSpec& d, uint32_t seed, const std::vector<Vec2>* keep) {
  if (d.style == "procedural" || !s.landform_detail() || change.box.empty() || d.strength <= 0) return false;
  float peak = 0;
  for (float v : change.v) peak = std::max(peak, std::abs(v));
  if (!(peak > 0)) return false;
  // Half a patch of context around the footprint, so the patches that cover its edge see the
  // ground beyond it.
  const Box box = grown(change.box, 8, s.grid());
  if (box.w < 16 || box.h < 16) return false;
  const Heightfield t = box_terrain(s, box, &change);
  const auto u = mixed_detail(s, t, box, style_mix(s, box, d), seed, d.strength);
  if (!u) return false;
  // The detail fades in over the first tenth of the change's peak, so the footprint's edge (where
  // the landform meets the ground) stays where the shape put it.
  const float ramp = 0.1f * peak;
  const double cell = std::max(s.grid().cell_x, s.grid().cell_y);
  for (int y = change.box.y0; y < change.box.y0 + change.box.h; ++y)
    for (int x = change.box.x0; x < change.box.x0 + change.box.w; ++x) {
      float& c = change.at(x, y);
      if (c == 0) continue;
      const float a = std::min(1.f, std::abs(c) / ramp);
      float w = a * a * (3 - 2 * a);
      if (keep) {
        const double k = std::min(1.0, distance_to(*keep, x * s.grid().cell_x, y * s.grid().cell_y) / (3 * cell));
        w *= float(k * k * (3 - 2 * k));
      }
      const size_t i = size_t(y - box.y0) * box.w + (x - box.x0);
      c += w * (u->z[i] - t.z[i]);
    }
  return true;
}

ShapeRaster paint_style(EditState& s, const std::string& style, const HostRegion& weight, bool retexture, double strength,
                        uint32_t seed) {
  s.add_style({style, weight});
  if (!retexture || weight.box.empty()) return {};
  s.height();  // the terrain under the region, solved
  const Box box = grown(weight.box, 8, s.grid());
  const Heightfield t = box_terrain(s, box, nullptr);
  std::map<std::string, std::vector<float>> mix;
  mix[style].assign(size_t(box.w) * box.h, 1.f);
  const auto u = mixed_detail(s, t, box, mix, seed, strength);
  if (!u) return {};
  ShapeRaster c(weight.box);
  for (int y = c.box.y0; y < c.box.y0 + c.box.h; ++y)
    for (int x = c.box.x0; x < c.box.x0 + c.box.w; ++x) {
      const size_t i = size_t(y - box.y0) * box.w + (x - box.x0);
      c.at(x, y) = float(weight.weight(x, y)) * (u->z[i] - t.z[i]);
    }
  return c;
}

Dictionary bundled_style_dictionary(const std::string& name) {
  const auto& names = bundled_styles();
  if (std::find(names.begin(), names.end(), name) == names.end())
    fail("amplify", "no bundled style '{}' (bundled: {})", name, fmt::format("{}", fmt::join(names, ", ")));
  return style_dictionary(nullptr, name, 0, 0)->dict;
}

}  // namespace terracl::edit
