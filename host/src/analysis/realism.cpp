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

double quantile_sorted(const std::vector<float>& v, double q) {
  if (v.empty()) return NAN;
  const double pos = q * double(v.size() - 1);
  const size_t a = size_t(pos);
  const size_t b = std::min(a + 1, v.size() - 1);
  return v[a] + (pos - double(a)) * (double(v[b]) - double(v[a]));
}

}  // namespace

std::vector<float> slope_degrees(const Heightfield& h) {
  std::vector<float> s(h.size(), NAN);
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const float c = h.at(x, y);
      if (std::isnan(c)) continue;
      const double a = clamped(h, x - 1, y - 1, c), b = clamped(h, x, y - 1, c), cc = clamped(h, x + 1, y - 1, c);
      const double d = clamped(h, x - 1, y, c), f = clamped(h, x + 1, y, c);
      const double g = clamped(h, x - 1, y + 1, c), hh = clamped(h, x, y + 1, c), i = clamped(h, x + 1, y + 1, c);
      const double dzdx = ((cc + 2 * f + i) - (a + 2 * d + g)) / (8 * cx);
      const double dzdy = ((g + 2 * hh + i) - (a + 2 * b + cc)) / (8 * cy);
      s[size_t(y) * h.width + x] = float(std::atan(std::hypot(dzdx, dzdy)) * 180.0 / M_PI);
    }
  return s;
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
  const HeightStats st = compute_stats(h);
  if (st.valid == 0) fail(stage, "the heightfield has no valid cell");
  json j;
  j["width"] = h.width;
  j["height"] = h.height;
  j["cell_x_m"] = h.georef.cell_x;
  j["cell_y_m"] = h.georef.cell_y;
  j["valid_cells"] = st.valid;
  j["nodata_cells"] = st.nodata;
  const double area = double(st.valid) * h.georef.cell_x * h.georef.cell_y;
  j["area_m2"] = area;
  j["elevation"] = {{"min_m", st.min}, {"max_m", st.max}, {"mean_m", st.mean}, {"relief_m", st.max - st.min}};
  j["hypsometric_integral"] = st.max > st.min ? (st.mean - st.min) / (st.max - st.min) : 0.0;

  // Slope distribution.
  std::vector<float> s = slope_degrees(h);
  s.erase(std::remove_if(s.begin(), s.end(), [](float v) { return std::isnan(v); }), s.end());
  std::sort(s.begin(), s.end());
  double smean = 0;
  for (float v : s) smean += v;
  smean /= double(s.size());
  json hist = json::array();
  {
    std::vector<size_t> bins(18, 0);  // 5-degree bins
    for (float v : s) bins[std::min<size_t>(17, size_t(v / 5.0f))]++;
    for (size_t b = 0; b < bins.size(); ++b) hist.push_back(double(bins[b]) / double(s.size()));
  }
  j["slope_deg"] = {{"mean", smean},
                    {"max", s.back()},
                    {"quantiles",
                     {{"p05", quantile_sorted(s, 0.05)},
                      {"p25", quantile_sorted(s, 0.25)},
                      {"p50", quantile_sorted(s, 0.50)},
                      {"p75", quantile_sorted(s, 0.75)},
                      {"p95", quantile_sorted(s, 0.95)}}},
                    {"histogram_5deg", hist}};
  report_progress(progress, stage, 0.1, "slope");

  // Laplacian curvature (1/m) on interior cells with valid 4-neighbours.
  {
    const double cx2 = h.georef.cell_x * h.georef.cell_x, cy2 = h.georef.cell_y * h.georef.cell_y;
    double sum = 0, sum2 = 0, cnt = 0, pos = 0;
    for (int y = 1; y < h.height - 1; ++y)
      for (int x = 1; x < h.width - 1; ++x) {
        const double c = h.at(x, y), e = h.at(x + 1, y), wv = h.at(x - 1, y), n = h.at(x, y - 1), so = h.at(x, y + 1);
        const double lap = (e + wv - 2 * c) / cx2 + (n + so - 2 * c) / cy2;
        if (std::isnan(lap)) continue;
        sum += lap, sum2 += lap * lap, cnt += 1;
        if (lap > 0) pos += 1;
      }
    const double mean = cnt > 0 ? sum / cnt : 0.0;
    j["laplacian_per_m"] = {{"mean", mean},
                            {"std", cnt > 0 ? std::sqrt(std::max(0.0, sum2 / cnt - mean * mean)) : 0.0},
                            {"fraction_concave_up", cnt > 0 ? pos / cnt : 0.0}};
  }
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
