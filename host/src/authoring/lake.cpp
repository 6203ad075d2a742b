// SPDX-License-Identifier: Apache-2.0
// Lakes: the spill level of a basin, the cells a lake covers, and EditState's water layer, computed
// from the terrain when asked (docs/authoring.md, "Lakes").
#include "authoring/lake.hpp"

#include "authoring/state.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <queue>
#include <utility>

namespace terracl::edit {

namespace {

bool on_edge(const Heightfield& h, int x, int y) { return x == 0 || y == 0 || x == h.width - 1 || y == h.height - 1; }

template <typename F>
void for_neighbours(const Heightfield& h, size_t i, F&& f) {
  const int x = int(i % size_t(h.width)), y = int(i / size_t(h.width));
  if (x > 0) f(i - 1);
  if (x + 1 < h.width) f(i + 1);
  if (y > 0) f(i - size_t(h.width));
  if (y + 1 < h.height) f(i + size_t(h.width));
}

}  // namespace

SpillPoint spill_point(const Heightfield& h, int sx, int sy) {
  size_t seed = size_t(sy) * h.width + sx;
  if (!std::isfinite(h.z[seed])) return {h.z[seed], sx, sy, sx, sy, on_edge(h, sx, sy)};
  // Down to the bottom first: a flood started on the inner slope of a basin would meet the lower
  // cells of its own basin and stop there, as if it had spilled.
  for (;;) {
    size_t lowest = seed;
    for_neighbours(h, seed, [&](size_t n) {
      if (std::isfinite(h.z[n]) && h.z[n] < h.z[lowest]) lowest = n;
    });
    if (lowest == seed) break;
    seed = lowest;  // strictly lower each step: ends
  }
  const int px = int(seed % size_t(h.width)), py = int(seed / size_t(h.width));
  // Min-heap on (elevation, index): ties pop in index order, so the outlet is deterministic.
  using Item = std::pair<float, size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  std::vector<uint8_t> seen(h.size(), 0);
  open.push({h.z[seed], seed});
  seen[seed] = 1;
  double level = -std::numeric_limits<double>::infinity();
  size_t raiser = seed;  // the cell that set the level: the saddle when the water spills past it
  while (!open.empty()) {
    const auto [z, i] = open.top();
    open.pop();
    const int x = int(i % size_t(h.width)), y = int(i / size_t(h.width));
    // A cell below the water level, reached only over the level's cells: another basin.
    if (double(z) < level) return {level, px, py, int(raiser % size_t(h.width)), int(raiser / size_t(h.width)), false};
    if (double(z) > level) level = z, raiser = i;
    if (on_edge(h, x, y)) return {level, px, py, x, y, true};
    for_neighbours(h, i, [&](size_t n) {
      if (seen[n] || !std::isfinite(h.z[n])) return;
      seen[n] = 1;
      open.push({h.z[n], n});
    });
  }
  // Walled in by non-finite cells.
  return {level, px, py, int(raiser % size_t(h.width)), int(raiser / size_t(h.width)), false};
}

std::vector<size_t> lake_cells(const Heightfield& h, int sx, int sy, double level) {
  std::vector<size_t> cells;
  const size_t seed = size_t(sy) * h.width + sx;
  if (!(double(h.z[seed]) < level)) return cells;
  std::vector<uint8_t> seen(h.size(), 0);
  seen[seed] = 1;
  cells.push_back(seed);
  for (size_t k = 0; k < cells.size(); ++k)  // breadth first: `cells` is the queue
    for_neighbours(h, cells[k], [&](size_t n) {
      if (seen[n] || !(double(h.z[n]) < level)) return;  // NaN compares false: a wall
      seen[n] = 1;
      cells.push_back(n);
    });
  return cells;
}

const Heightfield* EditState::water() {
  if (m_lakes.empty()) return nullptr;
  // The lakes of a script are filled on its final terrain, not on the terrain at their place in the
  // script: a later edit that raises a dam or cuts an outlet changes the shore it leaves.
  const Heightfield& h = height();
  if (m_water && m_water_solves == m_solves && m_water_lakes == m_lakes.size()) return &*m_water;
  Heightfield w(h.width, h.height, 0.f);
  w.georef = h.georef;
  const double cell_area = m_grid.cell_x * m_grid.cell_y;
  m_lake_report = nlohmann::json::array();
  for (const Lake& l : m_lakes) {
    const auto t0 = std::chrono::steady_clock::now();
    const float ground = h.at(l.sx, l.sy);
    double level = l.value;
    std::optional<SpillPoint> spill;
    if (l.rule == Lake::Spill) {
      spill = spill_point(h, l.sx, l.sy);
      level = spill->level;
    } else if (l.rule == Lake::Depth) {
      level = double(ground) + l.value;
    }
    const std::vector<size_t> cells = lake_cells(h, l.sx, l.sy, level);
    double volume = 0, deepest = 0;
    bool reaches_edge = false;  // at a given level the water may run off the map there
    for (size_t i : cells) {
      reaches_edge = reaches_edge || on_edge(h, int(i % size_t(h.width)), int(i / size_t(h.width)));
      const double d = level - double(h.z[i]);  // > 0: a lake cell is below the level
      volume += d;
      deepest = std::max(deepest, d);
      // The highest water surface wins where lakes overlap (depths over the same ground).
      w.z[i] = std::max(w.z[i], float(d));
    }
    nlohmann::json& entry = m_log.at(l.log_index);
    nlohmann::json fig = {{"rule", l.rule == Lake::Spill ? "spill" : l.rule == Lake::Level ? "level" : "depth"},
                          {"seed_cell", {l.sx, l.sy}},
                          {"level_m", level},
                          {"cells", cells.size()},
                          {"area_m2", double(cells.size()) * cell_area},
                          {"volume_m3", volume * cell_area},
                          {"max_depth_m", deepest},
                          {"reaches_edge", reaches_edge},
                          {"fill_ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()}};
    if (spill) {
      fig["pit_cell"] = {spill->pit_x, spill->pit_y};
      fig["spill_cell"] = {spill->x, spill->y};
      fig["spills_off_map"] = spill->edge;
    }
    std::vector<std::string> warnings = l.parse_warnings;
    if (cells.empty()) {
      if (spill && !(double(h.at(spill->pit_x, spill->pit_y)) < level))
        warnings.push_back(fmt::format(
            "{}: the seed cell ({}, {}) is not in a closed depression (the water there drains away{}), so the lake is "
            "empty: put the seed in a hollow, or give \"level\" or \"depth\"",
            l.path, l.sx, l.sy, spill->edge ? " off the map" : ""));
      else if (spill)
        warnings.push_back(fmt::format(
            "{}: the seed cell ({}, {}), at {:.6g} m, is not below the spill level {:.6g} m of the depression it drains "
            "into (lowest cell ({}, {})), so the lake is empty: put the seed lower in the basin, or give \"level\" or "
            "\"depth\"",
            l.path, l.sx, l.sy, ground, level, spill->pit_x, spill->pit_y));
      else
        warnings.push_back(fmt::format("{}: the terrain at the seed cell ({}, {}), {:.6g} m, is not below the lake's "
                                       "level {:.6g} m, so the lake is empty (expected a seed below the level)",
                                       l.path, l.sx, l.sy, ground, level));
    }
    for (auto it = fig.begin(); it != fig.end(); ++it) entry[it.key()] = it.value();
    if (warnings.empty())
      entry.erase("warnings");
    else
      entry["warnings"] = warnings;
    fig["index"] = entry.value("index", l.log_index);
    if (!warnings.empty()) fig["warnings"] = warnings;
    m_lake_report.push_back(std::move(fig));
  }
  m_water = std::move(w);
  m_water_solves = m_solves;
  m_water_lakes = m_lakes.size();
  return &*m_water;
}

}  // namespace terracl::edit
