// SPDX-License-Identifier: Apache-2.0
// The seam metric of tiled runs whose stages are not exact (erosion): a seam is a kink along a tile
// border, so it shows as second differences larger on the border rows/columns than elsewhere.
#include <cmath>
#include <terracl/tile.hpp>

namespace terracl {

double tile_seam_ratio(const Heightfield& h, int tile) {
  if (tile < 2 || h.width < 3 || h.height < 3) return NAN;
  double border = 0, other = 0;
  size_t nb = 0, no = 0;
  auto add = [&](double a, double b, double c, bool on_border) {
    const double d = a - 2 * b + c;
    if (!std::isfinite(d)) return;
    (on_border ? border : other) += d * d;
    ++(on_border ? nb : no);
  };
  // The cells on either side of a border between tiles (i % tile == 0 and i % tile == tile - 1,
  // excluding the raster's edge, whose second differences are not defined).
  auto is_border = [&](int i) { return i % tile == 0 || i % tile == tile - 1; };
  for (int y = 0; y < h.height; ++y)
    for (int x = 1; x + 1 < h.width; ++x) add(h.at(x - 1, y), h.at(x, y), h.at(x + 1, y), is_border(x));
  for (int y = 1; y + 1 < h.height; ++y)
    for (int x = 0; x < h.width; ++x) add(h.at(x, y - 1), h.at(x, y), h.at(x, y + 1), is_border(y));
  if (nb == 0 || no == 0 || other <= 0) return NAN;
  return (border / double(nb)) / (other / double(no));
}

}  // namespace terracl
