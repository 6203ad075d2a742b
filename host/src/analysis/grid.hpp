// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small shared pieces of the analysis modules: priority keys, outlet seeding, neighbour distances.
#include <algorithm>
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

/// Distances to the 8 neighbours in metres.
inline void neighbour_distances(const Heightfield& h, double d[8]) {
  const double cx = h.georef.cell_x, cy = h.georef.cell_y, dg = std::hypot(cx, cy);
  for (int k = 0; k < 8; ++k) d[k] = (kDx[k] != 0 && kDy[k] != 0) ? dg : (kDx[k] != 0 ? cx : cy);
}

/// Steepest-descent (D8) neighbour of cell (x, y) of a w x h grid `z` (row-major, NaN nodata;
/// cells outside the grid do not exist); kOutlet when no neighbour is lower. off[k] = kDy[k] * w +
/// kDx[k]. Shared by the untiled and the tiled accumulation, so both see the same bits.
inline uint8_t d8_receiver(const float* z, int w, int h, int x, int y, const ptrdiff_t off[8],
                           const double inv_dist[8]) {
  const size_t i = size_t(y) * w + x;
  const float zc = z[i];
  const bool interior = x > 0 && y > 0 && x < w - 1 && y < h - 1;
  double best = 0;
  uint8_t dir = kOutlet;
  for (int k = 0; k < 8; ++k) {
    if (!interior) {
      const int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
    }
    const float zn = z[size_t(ptrdiff_t(i) + off[k])];
    if (!(zn < zc)) continue;  // also skips NaN
    const double s = (double(zc) - double(zn)) * inv_dist[k];
    if (s > best) {  // strict: the lowest k wins ties
      best = s;
      dir = uint8_t(k);
    }
  }
  return dir;
}

constexpr size_t kAllDrain = size_t(-1);

/// Whether every valid cell of a w x h grid has a strictly lower neighbour or is an outlet (a
/// nodata or off-grid neighbour): then D8 routes every cell to the grid's edge or to nodata with
/// no depression or flat to resolve. Returns kAllDrain, or the index of the first cell that does
/// not drain (a pit or a flat cell).
inline size_t surface_drains(const float* z, int w, int h, const ptrdiff_t off[8]) {
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      const float zc = z[i];
      if (std::isnan(zc)) continue;
      if (x == 0 || y == 0 || x == w - 1 || y == h - 1) continue;
      bool drains = false;
      for (int k = 0; k < 8 && !drains; ++k) {
        const float zn = z[size_t(ptrdiff_t(i) + off[k])];
        drains = std::isnan(zn) || zn < zc;
      }
      if (!drains) return i;
    }
  return kAllDrain;
}

/// Calls outlet(x, y) for every outlet of a w x h grid, in row-major order: a valid cell (valid(x, y))
/// with an off-grid or invalid neighbour. Without nodata only the border is looked at.
template <class Valid, class Outlet>
void for_each_outlet(int w, int h, bool any_nodata, const Valid& valid, const Outlet& outlet) {
  for (int y = 0; y < h; ++y) {
    const bool border_row = (y == 0 || y == h - 1);
    for (int x = 0; x < w; ++x) {
      if (!border_row && !any_nodata && x != 0 && x != w - 1) {
        x = w - 2;  // interior cells of a grid without nodata are never outlets
        continue;
      }
      if (!valid(x, y)) continue;
      bool open_side = false;
      for (int k = 0; k < 8 && !open_side; ++k) {
        const int xn = x + kDx[k], yn = y + kDy[k];
        open_side = xn < 0 || yn < 0 || xn >= w || yn >= h || !valid(xn, yn);
      }
      if (open_side) outlet(x, y);
    }
  }
}

/// The grid with a one-cell nodata frame: every valid cell then has 8 addressable neighbours, so
/// the flood loops need no bounds checks and no divisions, and "border cell" and "next to nodata"
/// become the same test. Padded indices keep the row-major order of the original ones, so
/// index tie-breaking is unchanged.
struct Padded {
  int w = 0, h = 0, pw = 0;
  std::vector<float> z;         ///< (w + 2) * (h + 2), frame NaN
  std::vector<uint8_t> closed;  ///< frame and nodata closed
  ptrdiff_t off[8];
  size_t index(int x, int y) const { return size_t(y + 1) * pw + size_t(x + 1); }

  explicit Padded(const Heightfield& src) : w(src.width), h(src.height), pw(src.width + 2) {
    z.assign(size_t(pw) * (h + 2), NAN);
    closed.assign(z.size(), 1);
    for (int y = 0; y < h; ++y) {
      const float* row = &src.z[size_t(y) * w];
      float* dst = &z[index(0, y)];
      uint8_t* cl = &closed[index(0, y)];
      for (int x = 0; x < w; ++x) {
        dst[x] = row[x];
        cl[x] = std::isnan(row[x]) ? 1 : 0;
      }
    }
    for (int k = 0; k < 8; ++k) off[k] = ptrdiff_t(kDy[k]) * pw + kDx[k];
  }
  /// Copies the interior back into `dst` (same size as the source).
  void unpad(std::vector<float>& dst) const {
    for (int y = 0; y < h; ++y) std::copy_n(&z[index(0, y)], w, &dst[size_t(y) * w]);
  }
  /// Pushes every outlet (a valid cell with a nodata or frame neighbour) and closes it.
  void seed_outlets(MinHeap& heap, bool any_nodata) {
    for_each_outlet(w, h, any_nodata, [&](int x, int y) { return !std::isnan(z[index(x, y)]); },
                    [&](int x, int y) {
                      const size_t i = index(x, y);
                      closed[i] = 1;
                      heap.push(key(z[i], i));
                    });
  }
};

/// Index space check (the keys hold 32-bit cell indices).
void require_indexable(const Heightfield& h, const char* stage);

}  // namespace terracl::analysis::detail
