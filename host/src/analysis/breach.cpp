// SPDX-License-Identifier: Apache-2.0
// Complete breaching (Lindsay 2016, "Efficient hybrid breaching-filling sink removal methods for
// flow path enforcement in digital elevation models", the complete-breaching variant): a priority
// flood from the outlets records, for every cell, the cell it was reached from (its back-link,
// i.e. its downstream neighbour on the cheapest way out). A cell lower than the cell that reached
// it is the bottom of a depression: the back-link path from there is cut down to its level.
#include <terracl/error.hpp>

#include "analysis/grid.hpp"

namespace terracl::analysis {

using namespace detail;

BreachResult breach_depressions(const Heightfield& h, bool raise_single_cell_pits, const Progress& progress) {
  const char* stage = "breach";
  require_indexable(h, stage);
  BreachResult r;
  r.breached = h;
  const size_t n = h.size();
  const double area = h.georef.cell_x * h.georef.cell_y;
  Padded g(h);
  std::vector<float>& z = g.z;
  const size_t valid = n - h.count_nodata();

  // Single-cell pits are usually data noise; Lindsay raises them rather than cut a channel. Two
  // pits are never neighbours, so raising one in place cannot change the test of another.
  if (raise_single_cell_pits) {
    const std::vector<float>& orig = z;
    double raised = 0;
    for (int y = 1; y < h.height - 1; ++y)
      for (int x = 1; x < h.width - 1; ++x) {
        const size_t i = g.index(x, y);
        const float zc = orig[i];
        if (std::isnan(zc)) continue;
        float lowest = INFINITY;
        bool pit = true;
        for (int k = 0; k < 8 && pit; ++k) {
          const float zn = orig[size_t(ptrdiff_t(i) + g.off[k])];
          if (!(zn > zc)) pit = false;  // a lower/equal or nodata neighbour: not a closed pit
          lowest = std::fmin(lowest, zn);
        }
        if (!pit) continue;
        z[i] = lowest;
        raised += double(lowest) - double(zc);
        r.pits_raised++;
      }
    r.raised_volume_m3 = raised * area;
  }

  std::vector<uint8_t>& closed = g.closed;
  std::vector<uint8_t> link(z.size(), kOutlet);  // back-link: direction to the downstream cell
  MinHeap open = make_heap(size_t(2 * (h.width + h.height)) + 1024);
  g.seed_outlets(open, h.count_nodata() > 0);

  size_t done = 0, next_report = n / 8 + 1;
  while (!open.empty()) {
    const size_t c = key_index(open.top());
    open.pop();
    for (int k = 0; k < 8; ++k) {
      const size_t m = size_t(ptrdiff_t(c) + g.off[k]);
      if (closed[m]) continue;
      closed[m] = 1;
      link[m] = uint8_t((k + 4) & 7);  // from m back to c
      const float zm = z[m];
      if (zm < z[c]) {
        // m is a depression bottom: lower its way out to zm. Everything downstream of a cell at or
        // below zm is lower still (cells pop in non-decreasing order), so the walk can stop there.
        size_t p = c;
        while (z[p] > zm) {
          z[p] = zm;
          if (link[p] == kOutlet) break;
          p = size_t(ptrdiff_t(p) + g.off[link[p]]);
        }
      }
      open.push(key(zm, m));
    }
    if (++done >= next_report) {
      report_progress(progress, stage, double(done) / n, "priority flood");
      next_report += n / 8 + 1;
    }
  }
  g.unpad(r.breached.z);

  double sum = 0;
  for (size_t i = 0; i < n; ++i) {
    const double d = double(h.z[i]) - double(r.breached.z[i]);
    if (d > 0) {
      sum += d;
      r.cells_lowered++;
      if (d > r.max_depth_m) r.max_depth_m = d;
    }
  }
  r.volume_m3 = sum * area;
  r.mean_depth_m = valid ? sum / double(valid) : 0.0;
  r.mean_depth_breached_m = r.cells_lowered ? sum / double(r.cells_lowered) : 0.0;
  return r;
}

}  // namespace terracl::analysis
