// SPDX-License-Identifier: Apache-2.0
// Realism statistics: the numbers the terrain-synthesis literature compares generated terrains
// with (slope distribution, curvature, spectral slope, hypsometry, drainage concentration,
// breaching volume as in Perche et al. 2023, section 5.4).
#include <fmt/format.h>

#include <algorithm>
#include <complex>
#include <numeric>
#include <terracl/error.hpp>
#include <unsupported/Eigen/FFT>

#include "analysis/grid.hpp"
#include "analysis/local_metrics.hpp"

namespace terracl::analysis {

using json = nlohmann::json;
using namespace detail;

namespace {

/// Value at (x, y) clamped to the grid; a nodata neighbour is replaced by the centre value so that
/// the 3x3 stencils stay finite next to voids.
inline float clamped(const Heightfield& h, int x, int y, float centre) {
  x = std::clamp(x, 0, h.width - 1);
  y = std::clamp(y, 0, h.height - 1);
  const float v = h.at(x, y);
  return std::isnan(v) ? centre : v;
}

}  // namespace

namespace {

// Horn's slope at (x, y) of `h` (clamped at its edges), NaN on a nodata cell.
float slope_at(const Heightfield& h, int x, int y) {
  const float c = h.at(x, y);
  if (std::isnan(c)) return NAN;
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  const double a = clamped(h, x - 1, y - 1, c), b = clamped(h, x, y - 1, c), cc = clamped(h, x + 1, y - 1, c);
  const double d = clamped(h, x - 1, y, c), f = clamped(h, x + 1, y, c);
  const double g = clamped(h, x - 1, y + 1, c), hh = clamped(h, x, y + 1, c), i = clamped(h, x + 1, y + 1, c);
  const double dzdx = ((cc + 2 * f + i) - (a + 2 * d + g)) / (8 * cx);
  const double dzdy = ((g + 2 * hh + i) - (a + 2 * b + cc)) / (8 * cy);
  return float(std::atan(std::hypot(dzdx, dzdy)) * 180.0 / M_PI);
}

}  // namespace

std::vector<float> slope_degrees(const Heightfield& h) {
  std::vector<float> s(h.size(), NAN);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) s[size_t(y) * h.width + x] = slope_at(h, x, y);
  return s;
}

void LocalMetrics::merge(const LocalMetrics& o) {
  valid += o.valid, nodata += o.nodata;
  zmin = std::min(zmin, o.zmin), zmax = std::max(zmax, o.zmax);
  z_sum.merge(o.z_sum);
  slope_max = std::max(slope_max, o.slope_max);
  slope_sum.merge(o.slope_sum);
  for (size_t b = 0; b < slope_bins.size(); ++b) slope_bins[b] += o.slope_bins[b];
  lap_sum.merge(o.lap_sum), lap_sum2.merge(o.lap_sum2);
  lap_n += o.lap_n, lap_pos += o.lap_pos;
}

void accumulate_local_metrics(const Heightfield& win, int wx, int wy, int cx, int cy, int cw, int ch, int W, int H,
                              LocalMetrics& m, std::vector<float>& slopes) {
  const double cx2 = win.georef.cell_x * win.georef.cell_x, cy2 = win.georef.cell_y * win.georef.cell_y;
  for (int gy = cy; gy < cy + ch; ++gy)
    for (int gx = cx; gx < cx + cw; ++gx) {
      const int x = gx - wx, y = gy - wy;
      const float v = win.at(x, y);
      if (!std::isfinite(v)) {
        ++m.nodata;
        continue;
      }
      ++m.valid;
      m.zmin = std::min<double>(m.zmin, v), m.zmax = std::max<double>(m.zmax, v);
      m.z_sum.add(v);
      // The window holds the cell's 3x3 neighbours, or ends where the raster does (clamped alike).
      const float s = slope_at(win, x, y);
      slopes.push_back(s);
      m.slope_max = std::max(m.slope_max, s);
      m.slope_sum.add(s);
      m.slope_bins[std::min<size_t>(17, size_t(s / 5.0f))]++;
    }
  // Laplacian curvature (1/m) on the raster's interior cells with valid 4-neighbours.
  for (int gy = std::max(cy, 1); gy < std::min(cy + ch, H - 1); ++gy)
    for (int gx = std::max(cx, 1); gx < std::min(cx + cw, W - 1); ++gx) {
      const int x = gx - wx, y = gy - wy;
      const double c = win.at(x, y), e = win.at(x + 1, y), wv = win.at(x - 1, y), n = win.at(x, y - 1),
                   so = win.at(x, y + 1);
      const double lap = (e + wv - 2 * c) / cx2 + (n + so - 2 * c) / cy2;
      if (std::isnan(lap)) continue;
      m.lap_sum.add(lap), m.lap_sum2.add(lap * lap), ++m.lap_n;
      if (lap > 0) ++m.lap_pos;
    }
}

std::pair<size_t, size_t> quantile_ranks(size_t n, double q) {
  const double pos = q * double(n - 1);
  const size_t a = size_t(pos);
  return {a, std::min(a + 1, n - 1)};
}

double quantile_between(size_t n, double q, float va, float vb) {
  const double pos = q * double(n - 1);
  return va + (pos - double(size_t(pos))) * (double(vb) - double(va));
}

json local_metrics_json(const LocalMetrics& m, const std::array<double, 5>& quantiles, int W, int H, double cell_x,
                        double cell_y) {
  json j;
  j["width"] = W;
  j["height"] = H;
  j["cell_x_m"] = cell_x;
  j["cell_y_m"] = cell_y;
  j["valid_cells"] = m.valid;
  j["nodata_cells"] = m.nodata;
  const double area = double(m.valid) * cell_x * cell_y;
  j["area_m2"] = area;
  const double mean = m.z_sum.value() / double(m.valid);
  j["elevation"] = {{"min_m", m.zmin}, {"max_m", m.zmax}, {"mean_m", mean}, {"relief_m", m.zmax - m.zmin}};
  j["hypsometric_integral"] = m.zmax > m.zmin ? (mean - m.zmin) / (m.zmax - m.zmin) : 0.0;
  json hist = json::array();
  for (uint64_t b : m.slope_bins) hist.push_back(double(b) / double(m.valid));
  j["slope_deg"] = {{"mean", m.slope_sum.value() / double(m.valid)},
                    {"max", m.slope_max},
                    {"quantiles",
                     {{"p05", quantiles[0]},
                      {"p25", quantiles[1]},
                      {"p50", quantiles[2]},
                      {"p75", quantiles[3]},
                      {"p95", quantiles[4]}}},
                    {"histogram_5deg", hist}};
  const double n = double(m.lap_n);
  const double lmean = m.lap_n > 0 ? m.lap_sum.value() / n : 0.0;
  j["laplacian_per_m"] = {
      {"mean", lmean},
      {"std", m.lap_n > 0 ? std::sqrt(std::max(0.0, m.lap_sum2.value() / n - lmean * lmean)) : 0.0},
      {"fraction_concave_up", m.lap_n > 0 ? double(m.lap_pos) / n : 0.0}};
  return j;
}

double gini(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  double sum = 0, weighted = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    sum += v[i];
    weighted += double(i + 1) * v[i];
  }
  if (sum <= 0) return 0.0;
  const double n = double(v.size());
  return 2.0 * weighted / (n * sum) - (n + 1.0) / n;
}

double spectral_slope(const Heightfield& h) {
  const int w = h.width, ht = h.height;
  if (w < 8 || ht < 8) return NAN;
  // Remove the best-fit plane (a trend would dominate the low wavenumbers) and taper with a Hann
  // window (the implicit periodic extension would otherwise add a k^-2 edge spectrum).
  double sx = 0, sy = 0, sz = 0, sxx = 0, syy = 0, sxz = 0, syz = 0, cnt = 0;
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = h.at(x, y);
      if (std::isnan(v)) continue;
      const double X = x - 0.5 * (w - 1), Y = y - 0.5 * (ht - 1);
      sx += X, sy += Y, sz += v, sxx += X * X, syy += Y * Y, sxz += X * v, syz += Y * v, cnt += 1;
    }
  if (cnt < 16) return NAN;
  const double mz = sz / cnt;
  // The grid is symmetric around its centre, so the plane fit separates (valid cells only approx.).
  const double bx = sxx > 0 ? (sxz - sx * mz) / sxx : 0, by = syy > 0 ? (syz - sy * mz) / syy : 0;
  std::vector<std::complex<double>> data(size_t(w) * ht);
  for (int y = 0; y < ht; ++y) {
    const double wy = 0.5 - 0.5 * std::cos(2 * M_PI * y / (ht - 1));
    for (int x = 0; x < w; ++x) {
      const double wx = 0.5 - 0.5 * std::cos(2 * M_PI * x / (w - 1));
      const float v = h.at(x, y);
      const double X = x - 0.5 * (w - 1), Y = y - 0.5 * (ht - 1);
      const double d = std::isnan(v) ? 0.0 : double(v) - mz - bx * X - by * Y;
      data[size_t(y) * w + x] = d * wx * wy;
    }
  }
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> row(w), out(w), col(ht), outc(ht);
  for (int y = 0; y < ht; ++y) {
    std::copy(data.begin() + size_t(y) * w, data.begin() + size_t(y + 1) * w, row.begin());
    fft.fwd(out, row);
    std::copy(out.begin(), out.end(), data.begin() + size_t(y) * w);
  }
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < ht; ++y) col[y] = data[size_t(y) * w + x];
    fft.fwd(outc, col);
    for (int y = 0; y < ht; ++y) data[size_t(y) * w + x] = outc[y];
  }
  // Radial bins in cycles per metre, one bin per fundamental of the shorter side.
  const double lx = w * h.georef.cell_x, ly = ht * h.georef.cell_y;
  const double dk = 1.0 / std::max(lx, ly);
  const double kmax = 0.5 / std::max(h.georef.cell_x, h.georef.cell_y);  // isotropic Nyquist
  const int nbins = int(kmax / dk);
  if (nbins < 4) return NAN;
  std::vector<double> psum(nbins + 1, 0.0), pcnt(nbins + 1, 0.0);
  for (int y = 0; y < ht; ++y) {
    const double ky = (y <= ht / 2 ? y : y - ht) / ly;
    for (int x = 0; x < w; ++x) {
      const double kx = (x <= w / 2 ? x : x - w) / lx;
      const double k = std::hypot(kx, ky);
      const int b = int(std::lround(k / dk));
      if (b < 1 || b > nbins) continue;
      psum[b] += std::norm(data[size_t(y) * w + x]);
      pcnt[b] += 1;
    }
  }
  // Least-squares line through (log k, log P), skipping the two lowest bins (window leakage).
  double a = 0, bsum = 0, ab = 0, aa = 0, m = 0;
  for (int b = 3; b <= nbins; ++b) {
    if (pcnt[b] == 0 || psum[b] <= 0) continue;
    const double lk = std::log10(b * dk), lp = std::log10(psum[b] / pcnt[b]);
    a += lk, bsum += lp, ab += lk * lp, aa += lk * lk, m += 1;
  }
  if (m < 3) return NAN;
  const double denom = m * aa - a * a;
  return denom > 0 ? (m * ab - a * bsum) / denom : NAN;
}

json terrain_metrics(const Heightfield& h, const Progress& progress) {
  const char* stage = "metrics";
  require_indexable(h, stage);
  // The local statistics as a tiled run gathers them (exact sums; tile/metrics_tiles.cpp).
  LocalMetrics m;
  std::vector<float> s;
  s.reserve(h.size());
  accumulate_local_metrics(h, 0, 0, 0, 0, h.width, h.height, h.width, h.height, m, s);
  if (m.valid == 0) fail(stage, "the heightfield has no valid cell");
  std::sort(s.begin(), s.end());
  std::array<double, 5> q{};
  for (size_t i = 0; i < kMetricQuantiles.size(); ++i) {
    const auto [a, b] = quantile_ranks(s.size(), kMetricQuantiles[i]);
    q[i] = quantile_between(s.size(), kMetricQuantiles[i], s[a], s[b]);
  }
  std::vector<float>().swap(s);
  json j = local_metrics_json(m, q, h.width, h.height, h.georef.cell_x, h.georef.cell_y);
  const double area = j["area_m2"].get<double>();
  report_progress(progress, stage, 0.1, "slope");
  const double beta = spectral_slope(h);
  j["spectral_slope"] = std::isnan(beta) ? json(nullptr) : json(beta);
  report_progress(progress, stage, 0.25, "spectrum");

  const FillResult f = priority_flood_fill(h, false);
  j["fill"] = {{"volume_m3", f.volume_m3},
               {"mean_depth_m", f.volume_m3 / area},
               {"max_depth_m", f.max_depth_m},
               {"cells", f.cells_raised}};
  report_progress(progress, stage, 0.45, "fill");
  const BreachResult b = breach_depressions(h, true);
  j["breach"] = {
      {"volume_m3", b.volume_m3},     {"b_bar_m", b.mean_depth_m}, {"mean_depth_breached_m", b.mean_depth_breached_m},
      {"max_depth_m", b.max_depth_m}, {"cells", b.cells_lowered},  {"raised_volume_m3", b.raised_volume_m3},
      {"pits_raised", b.pits_raised}};
  report_progress(progress, stage, 0.7, "breach");
  const D8Result d8 = d8_flow(h);
  double amax = 0;
  size_t outlets = 0;
  for (size_t i = 0; i < d8.cells.size(); ++i) {
    amax = std::max(amax, d8.cells[i]);
    if (d8.dir[i] == kOutlet) outlets++;
  }
  std::vector<double> areas;
  areas.reserve(d8.valid_cells);
  for (size_t i = 0; i < d8.cells.size(); ++i)
    if (d8.dir[i] != kNoFlow) areas.push_back(d8.area_m2(i));
  j["drainage"] = {{"max_area_m2", amax * d8.cell_area_m2},
                   {"outlets", outlets},
                   {"outflow_cells", d8.outflow_cells},
                   {"gini_d8_area", gini(std::move(areas))}};
  report_progress(progress, stage, 1.0, "drainage");
  return j;
}

std::string format_metrics(const json& r) {
  std::string s;
  auto num = [&](const json& v, const char* f) {
    return v.is_null() ? std::string("n/a") : fmt::format(fmt::runtime(f), v.get<double>());
  };
  s += fmt::format("size:                 {} x {} cells of {:.2f} m x {:.2f} m ({:.4g} km2)\n", r["width"].get<int>(),
                   r["height"].get<int>(), r["cell_x_m"].get<double>(), r["cell_y_m"].get<double>(),
                   r["area_m2"].get<double>() / 1e6);
  const json& e = r["elevation"];
  s += fmt::format("elevation:            min {:.2f}  max {:.2f}  mean {:.2f}  relief {:.2f} m\n",
                   e["min_m"].get<double>(), e["max_m"].get<double>(), e["mean_m"].get<double>(),
                   e["relief_m"].get<double>());
  s += fmt::format("hypsometric integral: {:.4f}\n", r["hypsometric_integral"].get<double>());
  const json& sl = r["slope_deg"];
  const json& q = sl["quantiles"];
  s += fmt::format(
      "slope (deg):          mean {:.2f}  steepest {:.2f}  p05 {:.2f}  p25 {:.2f}  p50 {:.2f}  p75 {:.2f}  p95 "
      "{:.2f}\n",
      sl["mean"].get<double>(), sl["max"].get<double>(), q["p05"].get<double>(), q["p25"].get<double>(),
      q["p50"].get<double>(), q["p75"].get<double>(), q["p95"].get<double>());
  const json& lp = r["laplacian_per_m"];
  s += fmt::format("laplacian (1/m):      mean {:.3e}  std {:.3e}  concave-up {:.1f} %\n", lp["mean"].get<double>(),
                   lp["std"].get<double>(), 100 * lp["fraction_concave_up"].get<double>());
  s += fmt::format("spectral slope:       {}  (log P / log k of the radially averaged power spectrum)\n",
                   num(r["spectral_slope"], "{:.3f}"));
  const json& f = r["fill"];
  s += fmt::format("fill:                 {:.4g} m3 over {} cells (max {:.2f} m, mean {:.4f} m)\n",
                   f["volume_m3"].get<double>(), f["cells"].get<size_t>(), f["max_depth_m"].get<double>(),
                   f["mean_depth_m"].get<double>());
  const json& b = r["breach"];
  s += fmt::format(
      "breach:               b {:.4g} m3, b-bar {:.4f} m over {} cells (max {:.2f} m); {} single-cell pits raised "
      "({:.4g} m3)\n",
      b["volume_m3"].get<double>(), b["b_bar_m"].get<double>(), b["cells"].get<size_t>(),
      b["max_depth_m"].get<double>(), b["pits_raised"].get<size_t>(), b["raised_volume_m3"].get<double>());
  const json& d = r["drainage"];
  s += fmt::format("drainage (D8):        max area {:.4g} km2, {} outlets, Gini {:.4f}\n",
                   d["max_area_m2"].get<double>() / 1e6, d["outlets"].get<size_t>(), d["gini_d8_area"].get<double>());
  return s;
}

}  // namespace terracl::analysis
