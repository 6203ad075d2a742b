// SPDX-License-Identifier: Apache-2.0
#pragma once
// The terrain of the lake tests, with its answers known by construction, and the brute-force lake
// the tests compare with (a plain breadth-first search, independent of host/src/authoring/lake.cpp).
#include <terracl/heightfield.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace terracl::test {

/// 48 x 24 cells of 10 m: two bowls walled in by a 200 m rim (the grid's edge cells), basin A
/// (columns 1-22, floor 40-85 m, lowest at column 9) and basin B (columns 25-46, floor 20-70 m,
/// lowest at columns 35-36), each with one pit (no other local minimum), parted by a 150 m
/// wall (columns 23-24) with one 100 m gap at row 12: the saddle, so either basin spills at 100 m.
/// In A: an island at 110 m (cells 6-7 x 6-7), and a 30 m pit (cells 16-18 x 17-19) ringed at
/// 120 m: below the spill level but not connected to the rest of A.
inline Heightfield two_basins() {
  Heightfield h(48, 24);
  h.georef.cell_x = h.georef.cell_y = 10;
  h.georef.geotransform = {0, 10, 0, 0, 0, -10};
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const double ay = (y - 11.5) / 10.5;
      double z;
      if (x == 0 || y == 0 || x == h.width - 1 || y == h.height - 1)
        z = 200;
      else if (x == 23 || x == 24)
        z = y == 12 ? 100 : 150;
      else if (x < 23)
        z = 40 + 25 * std::pow((x - 9) / 13.0, 2) + 20 * ay * ay;
      else
        z = 20 + 25 * std::pow((x - 35.5) / 10.5, 2) + 25 * ay * ay;
      if (x >= 6 && x <= 7 && y >= 6 && y <= 7) z = 110;
      if (x >= 15 && x <= 19 && y >= 16 && y <= 20) z = (x == 15 || x == 19 || y == 16 || y == 20) ? 120 : 30;
      h.at(x, y) = float(z);
    }
  return h;
}

/// Seeds (metres from the centre of cell (0, 0)) in basin A (on its floor's slope, two cells east of
/// its lowest cells) and basin B.
constexpr double kSeedA[2] = {110, 110}, kSeedB[2] = {350, 110};

/// The lake by brute force: depth level - h on the cells below `level` 4-connected to the seed
/// cell through such cells, 0 elsewhere.
inline std::vector<float> brute_force_lake(const Heightfield& h, int sx, int sy, double level) {
  std::vector<float> depth(h.size(), 0.f);
  std::vector<uint8_t> seen(h.size(), 0);
  std::vector<std::pair<int, int>> stack;
  if (double(h.at(sx, sy)) < level) stack.push_back({sx, sy});
  while (!stack.empty()) {
    const auto [x, y] = stack.back();
    stack.pop_back();
    if (x < 0 || y < 0 || x >= h.width || y >= h.height) continue;
    const size_t i = size_t(y) * h.width + x;
    if (seen[i] || !(double(h.z[i]) < level)) continue;
    seen[i] = 1;
    depth[i] = float(level - double(h.z[i]));
    stack.push_back({x + 1, y});
    stack.push_back({x - 1, y});
    stack.push_back({x, y + 1});
    stack.push_back({x, y - 1});
  }
  return depth;
}

}  // namespace terracl::test
