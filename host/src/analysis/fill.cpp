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

// `owned`, when given, is `h` itself, whose cells become the result's.
FillResult flood(const Heightfield& h, Heightfield* owned, bool epsilon, const Progress& progress) {
  const char* stage = "fill";
  require_indexable(h, stage);
  const size_t n = h.size();
  Padded g(h);
  std::vector<float>& z = g.z;
  std::vector<uint8_t>& closed = g.closed;
  MinHeap open = make_heap(size_t(2 * (h.width + h.height)) + 1024);
  g.seed_outlets(open, h.count_nodata() > 0);
  std::vector<uint32_t> pit;  // FIFO as a vector with a moving head (cheaper than std::deque)
  pit.reserve(1024);
  size_t pit_head = 0;

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
    for (int k = 0; k < 8; ++k) {
      const size_t m = size_t(ptrdiff_t(c) + g.off[k]);
      if (closed[m]) continue;
      closed[m] = 1;
      if (z[m] <= zmin) {
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
  // The flood's work memory goes before the output is made.
  open = MinHeap();
  std::vector<uint8_t>().swap(closed);
  std::vector<uint32_t>().swap(pit);
  FillResult r;
  const double area = h.georef.cell_x * h.georef.cell_y;
  double sum = 0;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const double d = double(z[g.index(x, y)]) - double(h.z[size_t(y) * h.width + x]);
      if (d > 0) {
        sum += d;
        r.cells_raised++;
        if (d > r.max_depth_m) r.max_depth_m = d;
      }
    }
  r.volume_m3 = sum * area;
  if (owned)
    r.filled = std::move(*owned);
  else
    r.filled = h;
  g.unpad(r.filled.z);
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
