// SPDX-License-Identifier: Apache-2.0
// Priority-Flood depression filling (Barnes, Lehman & Mulla 2014, "Priority-Flood: An optimal
// depression-filling and watershed-labeling algorithm for digital elevation models", Algorithms 2
// and 3). Cells inside depressions and on flats are processed through a plain FIFO queue instead
// of the heap, which is what makes the "improved" variant fast.
#include <deque>
#include <terracl/error.hpp>

#include "analysis/grid.hpp"

namespace terracl::analysis {

namespace detail {
void require_indexable(const Heightfield& h, const char* stage) {
  if (h.width <= 0 || h.height <= 0 || h.z.size() != size_t(h.width) * h.height)
    fail(stage, "empty or inconsistent heightfield ({} x {})", h.width, h.height);
  if (size_t(h.width + 2) * size_t(h.height + 2) >= (size_t(1) << 32))
    fail(stage, "grid of {} cells is too large (limit 2^32)", h.z.size());
  for (float v : h.z)
    if (std::isinf(v)) fail(stage, "heightfield has infinite elevations");
}
}  // namespace detail

using namespace detail;

namespace {

// `owned`, when given, is `h` itself, whose cells become the result's (its statistics are then
// summed in the flood's order). The flood works on the result's own cells, unpadded: a one-cell
// frame of the byte-per-cell `closed` array stands for the grid's border, so the loop still needs no
// bounds checks, and no padded copy of the raster is made (8193^2: 268 MB). Heap keys carry the
// row-major index, so equal elevations pop in the same order as on a padded grid.
FillResult flood(const Heightfield& h, Heightfield* owned, bool epsilon, const Progress& progress) {
  const char* stage = "fill";
  require_indexable(h, stage);
  const int w = h.width, ht = h.height, pw = w + 2;
  const size_t n = h.size();
  const double area = h.georef.cell_x * h.georef.cell_y;
  const bool any_nodata = h.count_nodata() > 0;
  FillResult r;
  if (owned)
    r.filled = std::move(*owned);  // `h` is *owned: not read below
  else
    r.filled = h;
  std::vector<float>& z = r.filled.z;
  std::vector<uint8_t> closed(size_t(pw) * (ht + 2), 1);  // frame and nodata closed
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) closed[size_t(y + 1) * pw + x + 1] = std::isnan(z[size_t(y) * w + x]) ? 1 : 0;
  ptrdiff_t poff[8], zoff[8];
  for (int k = 0; k < 8; ++k) poff[k] = ptrdiff_t(kDy[k]) * pw + kDx[k], zoff[k] = ptrdiff_t(kDy[k]) * w + kDx[k];
  MinHeap open = make_heap(size_t(2 * (w + ht)) + 1024);
  for_each_outlet(w, ht, any_nodata, [&](int x, int y) { return !std::isnan(z[size_t(y) * w + x]); },
                  [&](int x, int y) {
                    const size_t i = size_t(y) * w + x;
                    closed[size_t(y + 1) * pw + x + 1] = 1;
                    open.push(key(z[i], i));
                  });
  std::vector<uint32_t> pit;  // FIFO as a vector with a moving head (cheaper than std::deque)
  pit.reserve(1024);
  size_t pit_head = 0;
  double sum = 0;  // the owned path's statistics, as cells are raised

  size_t done = 0, next_report = n / 8 + 1;
  while (!open.empty() || pit_head < pit.size()) {
    size_t c;
    if (pit_head < pit.size()) {
      c = pit[pit_head++];
      if (pit_head == pit.size()) {
        pit.clear();
        pit_head = 0;
      }
    } else {
      c = key_index(open.top());
      open.pop();
    }
    const float zc = z[c];
    const float zmin = epsilon ? std::nextafter(zc, INFINITY) : zc;
    const size_t cy = c / size_t(w), pc = (cy + 1) * pw + (c - cy * w) + 1;
    for (int k = 0; k < 8; ++k) {
      const size_t pm = size_t(ptrdiff_t(pc) + poff[k]);
      if (closed[pm]) continue;
      closed[pm] = 1;
      const size_t m = size_t(ptrdiff_t(c) + zoff[k]);
      if (z[m] <= zmin) {
        if (owned) {
          const double d = double(zmin) - double(z[m]);
          if (d > 0) {
            sum += d;
            r.cells_raised++;
            if (d > r.max_depth_m) r.max_depth_m = d;
          }
        }
        z[m] = zmin;
        pit.push_back(uint32_t(m));
      } else {
        open.push(key(z[m], m));
      }
    }
    if (++done >= next_report) {
      report_progress(progress, stage, double(done) / n, "priority flood");
      next_report += n / 8 + 1;
    }
  }
  if (!owned)
    for (size_t i = 0; i < n; ++i) {
      const double d = double(z[i]) - double(h.z[i]);
      if (d > 0) {
        sum += d;
        r.cells_raised++;
        if (d > r.max_depth_m) r.max_depth_m = d;
      }
    }
  r.volume_m3 = sum * area;
  return r;
}

}  // namespace

FillResult priority_flood_fill(const Heightfield& h, bool epsilon, const Progress& progress) {
  return flood(h, nullptr, epsilon, progress);
}

FillResult priority_flood_fill(Heightfield&& h, bool epsilon, const Progress& progress) {
  return flood(h, &h, epsilon, progress);
}

}  // namespace terracl::analysis
