// SPDX-License-Identifier: Apache-2.0
// Tiled extract (extract_tiles.hpp). The gradient of a cell reads its right and lower neighbours
// (staggered) or both neighbours (central): a halo of one cell gives every core cell the values
// the untiled kernel sees, and the window's edge rules are the raster's only where the window edge
// is the raster's. The mean elevation, which the gradient file carries for reconstruction, is a
// sum over the whole raster: the prepass adds the cells in the untiled order (row-major, in double).
#include "tile/extract_tiles.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <terracl/error.hpp>

namespace terracl::tile {

StageTiling extract_tiling(const json&) {
  StageTiling t;
  t.kind = TileKind::Local;
  t.halo = 1;
  t.prepass = [](const std::function<Heightfield(int, int, int, int)>& read, int w, int h) {
    // Bands of whole rows (about 4M cells each), so that the sum runs in the untiled order.
    const int rows = std::max(1, std::min(h, int((size_t(1) << 22) / size_t(std::max(w, 1)))));
    double sum = 0;
    size_t bad = 0;
    for (int y = 0; y < h; y += rows) {
      const Heightfield band = read(0, y, w, std::min(rows, h - y));
      bad += band.count_nodata();
      for (float v : band.z) sum += v;
    }
    const size_t n = size_t(w) * size_t(h);
    if (bad)  // the untiled stage's message (require_finite), counted over the whole level
      fail("extract",
           "the input heightfield has {} nodata/NaN cell{} of {}; this stage needs a complete grid (use "
           "--fill-nodata)",
           bad, bad == 1 ? "" : "s", n);
    return fmt::format("{:.17g}", sum / double(n));
  };
  return t;
}

double extract_prepass_mean(const std::string& prepass) { return std::strtod(prepass.c_str(), nullptr); }

}  // namespace terracl::tile
