#pragma once
// Small shared pieces of the analysis modules: priority keys, outlet seeding, neighbour distances.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <queue>
#include <terracl/analysis.hpp>
#include <vector>

namespace terracl::analysis::detail {

/// Monotone map of a finite float to uint32 so that keys compare like the floats.
inline uint32_t ordered_bits(float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

/// Priority key: elevation first, then cell index, so equal elevations pop in index order
/// (deterministic, and independent of the heap's internal layout).
inline uint64_t key(float z, size_t i) { return (uint64_t(ordered_bits(z)) << 32) | uint64_t(i); }
inline size_t key_index(uint64_t k) { return size_t(k & 0xffffffffu); }

using MinHeap = std::priority_queue<uint64_t, std::vector<uint64_t>, std::greater<uint64_t>>;

/// A heap with its storage reserved up front (pushes then never reallocate).
inline MinHeap make_heap(size_t reserve) {
  std::vector<uint64_t> storage;
  storage.reserve(reserve);
  return MinHeap(std::greater<uint64_t>(), std::move(storage));
}

/// True for valid cells where water can leave the grid: on the border or next to nodata.
inline bool is_outlet_cell(const Heightfield& h, int x, int y) {
  if (x == 0 || y == 0 || x == h.width - 1 || y == h.height - 1) return true;
  for (int k = 0; k < 8; ++k)
    if (std::isnan(h.at(x + kDx[k], y + kDy[k]))) return true;
  return false;
}

/// Distances to the 8 neighbours in metres.
inline void neighbour_distances(const Heightfield& h, double d[8]) {
  const double cx = h.georef.cell_x, cy = h.georef.cell_y, dg = std::hypot(cx, cy);
  for (int k = 0; k < 8; ++k) d[k] = (kDx[k] != 0 && kDy[k] != 0) ? dg : (kDx[k] != 0 ? cx : cy);
}

/// Pushes every outlet cell into `heap` and marks it closed. Interior rows only test the
/// neighbours of cells next to nodata when the grid has nodata at all (the common case is fast).
inline void seed_outlets(const Heightfield& h, std::vector<uint8_t>& closed, MinHeap& heap) {
  const int w = h.width, ht = h.height;
  const bool any_nan = h.count_nodata() > 0;
  for (int y = 0; y < ht; ++y) {
    const bool border_row = (y == 0 || y == ht - 1);
    for (int x = 0; x < w; ++x) {
      if (!border_row && !any_nan && x != 0 && x != w - 1) {
        x = w - 2;  // jump to the last column
        continue;
      }
      const size_t i = size_t(y) * w + x;
      const float z = h.z[i];
      if (std::isnan(z)) continue;
      if (is_outlet_cell(h, x, y)) {
        closed[i] = 1;
        heap.push(key(z, i));
      }
    }
  }
}

/// Index space check (the keys hold 32-bit cell indices).
void require_indexable(const Heightfield& h, const char* stage);

}  // namespace terracl::analysis::detail
