// SPDX-License-Identifier: Apache-2.0
#pragma once
// The tile grid and the one-cell-halo window read shared by the exact tiled global algorithms
// (fill_tiled.cpp, flow_tiled.cpp): both need each tile's core plus its neighbours' edge cells.
#include <terracl/error.hpp>
#include <terracl/tile.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace terracl::analysis::tiles {

struct Tile {
  int x0, y0, x1, y1;  // core
};

/// Row-major tiles of T x T cells (the last row/column of tiles may be smaller).
inline std::vector<Tile> make_tiles(int W, int H, int T) {
  std::vector<Tile> tiles;
  for (int y = 0; y < H; y += T)
    for (int x = 0; x < W; x += T) tiles.push_back({x, y, std::min(W, x + T), std::min(H, y + T)});
  return tiles;
}

/// Reads tile `t` with a one-cell halo clipped to the raster; (wx, wy) is the window's origin.
/// `stage` names the caller in errors.
inline Heightfield read_with_halo(const WindowReader& read, const Tile& t, int W, int H, int& wx, int& wy,
                                  const char* stage) {
  wx = std::max(0, t.x0 - 1), wy = std::max(0, t.y0 - 1);
  const int wx1 = std::min(W, t.x1 + 1), wy1 = std::min(H, t.y1 + 1);
  Heightfield win = read(wx, wy, wx1 - wx, wy1 - wy);
  if (win.width != wx1 - wx || win.height != wy1 - wy || win.z.size() != size_t(win.width) * win.height)
    fail(stage, "tile reader returned {} x {} cells for a {} x {} window", win.width, win.height, wx1 - wx,
         wy1 - wy);
  for (float v : win.z)
    if (std::isinf(v)) fail(stage, "heightfield has infinite elevations");
  return win;
}

/// An empty heightfield of tile `t`'s core with the window's metadata and its georeferencing moved
/// from the window's origin (wx, wy) to the core's.
inline Heightfield core_frame(const Heightfield& win, const Tile& t, int wx, int wy) {
  Heightfield core(t.x1 - t.x0, t.y1 - t.y0);
  core.georef = win.georef;
  core.metadata = win.metadata;
  auto& gt = core.georef.geotransform;
  if (core.georef.has_geotransform) {
    const int dx = t.x0 - wx, dy = t.y0 - wy;
    gt[0] += dx * gt[1] + dy * gt[2];
    gt[3] += dx * gt[4] + dy * gt[5];
  }
  return core;
}

}  // namespace terracl::analysis::tiles
