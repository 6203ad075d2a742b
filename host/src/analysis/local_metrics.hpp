// SPDX-License-Identifier: Apache-2.0
#pragma once
// The local statistics of the metrics report (elevation, slope, Laplacian curvature), gathered
// window by window into exact accumulators, so that a tiled run's report equals the untiled one
// bit for bit (realism.cpp; tile/metrics_tiles.cpp).
#include <array>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <terracl/heightfield.hpp>
#include <utility>
#include <vector>

#include "analysis/exact_sum.hpp"

namespace terracl::analysis {

/// The slope quantiles of the report (p05 p25 p50 p75 p95).
inline constexpr std::array<double, 5> kMetricQuantiles = {0.05, 0.25, 0.50, 0.75, 0.95};

struct LocalMetrics {
  uint64_t valid = 0, nodata = 0;
  double zmin = std::numeric_limits<double>::infinity(), zmax = -std::numeric_limits<double>::infinity();
  ExactSum z_sum;
  float slope_max = -std::numeric_limits<float>::infinity();
  ExactSum slope_sum;
  std::array<uint64_t, 18> slope_bins{};  // 5-degree bins
  ExactSum lap_sum, lap_sum2;
  uint64_t lap_n = 0, lap_pos = 0;
  void merge(const LocalMetrics& o);
};

/// Adds the cells [cx, cx + cw) x [cy, cy + ch) of a W x H raster, from `window` (which starts at
/// (wx, wy) and holds one more cell around the core where the raster has one); appends the core's
/// slopes (degrees) to `slopes`.
void accumulate_local_metrics(const Heightfield& window, int wx, int wy, int cx, int cy, int cw, int ch, int W, int H,
                              LocalMetrics& m, std::vector<float>& slopes);
/// Ranks (0-based, ascending) of the two values quantile q of n interpolates between.
std::pair<size_t, size_t> quantile_ranks(size_t n, double q);
/// Quantile q of n values from the values at quantile_ranks.
double quantile_between(size_t n, double q, float va, float vb);
/// The report's local fields (size, cells, elevation, hypsometric integral, slope, Laplacian).
nlohmann::json local_metrics_json(const LocalMetrics& m, const std::array<double, 5>& quantiles, int W, int H,
                                  double cell_x, double cell_y);

}  // namespace terracl::analysis
