// SPDX-License-Identifier: Apache-2.0
// Measures for amplification (scripts/eval-amplify.sh) and the compression report of section 5.1.
#include <terracl/amplify.hpp>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>

#include "row_spectra.hpp"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>

namespace terracl {

namespace {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

}  // namespace

std::vector<std::complex<double>> windowed_row_spectra(const Heightfield& h) {
  const int w = h.width, ht = h.height;
  // Plane fit z ~ a + b x + c y (x, y centred, so the normal equations are diagonal).
  double sz = 0, sxz = 0, syz = 0, sxx = 0, syy = 0;
  const double cx = 0.5 * (w - 1), cy = 0.5 * (ht - 1);
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const double z = h.at(x, y), dx = x - cx, dy = y - cy;
      sz += z, sxz += dx * z, syz += dy * z, sxx += dx * dx, syy += dy * dy;
    }
  const double a = sz / (double(w) * ht), b = sxx > 0 ? sxz / sxx : 0, c = syy > 0 ? syz / syy : 0;
  std::vector<std::complex<double>> grid(size_t(w) * ht);
  std::vector<double> hann_x(static_cast<size_t>(w));
  for (int x = 0; x < w; ++x) hann_x[size_t(x)] = 0.5 - 0.5 * std::cos(2 * M_PI * (x + 0.5) / w);
  // Rows in parallel: each is windowed and transformed on its own.
  parallel_for(size_t(ht), 0, [&](size_t y0, size_t y1) {
    Eigen::FFT<double> fft;
    std::vector<std::complex<double>> in, out;
    for (size_t y = y0; y < y1; ++y) {
      const double hann_y = 0.5 - 0.5 * std::cos(2 * M_PI * (double(y) + 0.5) / ht);
      for (int x = 0; x < w; ++x)
        grid[y * w + x] = hann_x[size_t(x)] * hann_y * (h.at(x, int(y)) - a - b * (x - cx) - c * (double(y) - cy));
      in.assign(grid.begin() + y * w, grid.begin() + (y + 1) * w);
      fft.fwd(out, in);
      std::copy(out.begin(), out.end(), grid.begin() + y * w);
    }
  });
  return grid;
}

// Spectrum outside the low-resolution passband |fx|, |fy| <= 1 / (2 f) (cycles per cell), of the
// plane-removed, Hann-windowed tile (windowed_row_spectra). Every step is linear in h.
std::vector<std::complex<double>> spectrum_above(const Heightfield& h, int f) {
  const int w = h.width, ht = h.height;
  const std::vector<std::complex<double>> grid = windowed_row_spectra(h);
  const double nyq = 0.5 / f;
  // Columns in parallel, each into its own list, joined in column order.
  std::vector<std::vector<std::complex<double>>> cols(static_cast<size_t>(w));
  parallel_for(size_t(w), 0, [&](size_t x0, size_t x1) {
    Eigen::FFT<double> fft;
    std::vector<std::complex<double>> in(static_cast<size_t>(ht)), out;
    for (size_t x = x0; x < x1; ++x) {
      for (int y = 0; y < ht; ++y) in[size_t(y)] = grid[size_t(y) * w + x];
      fft.fwd(out, in);
      const double fx = std::fabs(double(int(x) <= w / 2 ? int(x) : int(x) - w) / w);
      for (int y = 0; y < ht; ++y) {
        const double fy = std::fabs(double(y <= ht / 2 ? y : y - ht) / ht);
        if (fx > nyq || fy > nyq) cols[x].push_back(out[size_t(y)]);
      }
    }
  });
  std::vector<std::complex<double>> hf;
  size_t total = 0;
  for (const auto& c : cols) total += c.size();
  hf.reserve(total);
  for (const auto& c : cols) hf.insert(hf.end(), c.begin(), c.end());
  return hf;
}

double energy_above(const Heightfield& h, int f) {
  double e = 0;
  for (const auto& c : spectrum_above(h, f)) e += std::norm(c);
  return e;
}

namespace {
double rmse(const std::vector<float>& a, const std::vector<float>& b);
}  // namespace

std::vector<double> highpass(const Heightfield& h, int f) {
  const int r = (f + 1) / 2;
  std::vector<double> t(h.z.size()), out(h.z.size());
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      double s = 0;
      for (int u = -r; u <= r; ++u) s += h.at(clampi(x + u, h.width), y);
      t[size_t(y) * h.width + x] = s / (2 * r + 1);
    }
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      double s = 0;
      for (int v = -r; v <= r; ++v) s += t[size_t(clampi(y + v, h.height)) * h.width + x];
      out[size_t(y) * h.width + x] = h.at(x, y) - s / (2 * r + 1);
    }
  return out;
}

double roughness(const Heightfield& h, int f) {
  double acc = 0;
  for (double d : highpass(h, f)) acc += d * d;
  return std::sqrt(acc / double(std::max<size_t>(1, h.z.size())));
}

namespace {

double rmse(const std::vector<float>& a, const std::vector<float>& b) {
  double acc = 0;
  for (size_t i = 0; i < a.size(); ++i) acc += double(a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(acc / double(a.size()));
}

}  // namespace

AmplifyMetrics evaluate_amplification(const Heightfield& out, const Heightfield& truth, const Heightfield& low, int f,
                                      int patch_spacing) {
  if (out.width != truth.width || out.height != truth.height)
    fail("eval", "output {}x{} and truth {}x{} differ in size", out.width, out.height, truth.width, truth.height);
  if (low.width * f != truth.width || low.height * f != truth.height)
    fail("eval", "input {}x{} times {} is not the truth's {}x{}", low.width, low.height, f, truth.width, truth.height);
  AmplifyMetrics m;
  m.rmse = rmse(out.z, truth.z);
  const HeightStats ts = compute_stats(truth);
  m.psnr = 20 * std::log10((ts.max - ts.min) / std::max(1e-12, m.rmse));
  m.hf_ratio = energy_above(out, f) / std::max(1e-30, energy_above(truth, f));
  m.roughness_ratio = roughness(out, f) / std::max(1e-30, roughness(truth, f));
  m.slope_ratio = compute_stats(out).mean_slope_deg / std::max(1e-30, ts.mean_slope_deg);
  m.lr_consistency = rmse(block_mean(out, f).z, low.z);
  m.patch_peak = periodic_trace(out, patch_spacing).peak;
  m.block_peak = periodic_trace(out, f).peak;
  m.d8_agreement = d8_agreement(out, truth, 0.002, f);
  return m;
}

double d8_agreement(const Heightfield& out, const Heightfield& truth, double river_fraction, int tolerance) {
  if (out.width != truth.width || out.height != truth.height)
    fail("eval", "D8 agreement: output {}x{} and truth {}x{} differ in size", out.width, out.height, truth.width, truth.height);
  const int w = out.width, h = out.height;
  auto rivers = [&](const Heightfield& z) {
    const analysis::D8Result r = analysis::d8_flow(z);
    const double min_cells = std::max(2.0, river_fraction * double(r.valid_cells));
    std::vector<uint8_t> m(z.size());
    for (size_t i = 0; i < m.size(); ++i) m[i] = r.cells[i] >= min_cells;
    return m;
  };
  // Cells within `tolerance` of a river: separable max filter.
  auto dilate = [&](const std::vector<uint8_t>& m) {
    std::vector<uint8_t> t(m.size(), 0), d(m.size(), 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (m[size_t(y) * w + x])
          for (int u = std::max(0, x - tolerance); u <= std::min(w - 1, x + tolerance); ++u) t[size_t(y) * w + u] = 1;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (t[size_t(y) * w + x])
          for (int v = std::max(0, y - tolerance); v <= std::min(h - 1, y + tolerance); ++v) d[size_t(v) * w + x] = 1;
    return d;
  };
  const auto ro = rivers(out), rt = rivers(truth);
  const auto dout = dilate(ro), dtruth = dilate(rt);
  double hit_t = 0, n_t = 0, hit_o = 0, n_o = 0;
  for (size_t i = 0; i < ro.size(); ++i) {
    if (rt[i]) n_t += 1, hit_t += dout[i];
    if (ro[i]) n_o += 1, hit_o += dtruth[i];
  }
  if (n_t == 0 || n_o == 0) return 0;
  return 0.5 * (hit_t / n_t + hit_o / n_o);
}

PeriodicTrace periodic_trace(const Heightfield& h, int period) { return periodic_trace(std::vector<const Heightfield*>{&h}, period); }

PeriodicTrace periodic_trace(const std::vector<const Heightfield*>& hs, int period) {
  if (hs.empty() || !hs[0]) fail("eval", "periodic trace: no raster given");
  const int w = hs[0]->width, ht = hs[0]->height;
  for (const Heightfield* h : hs)
    if (!h || h->width != w || h->height != ht)
      fail("eval", "periodic trace: rasters of different sizes ({}x{} and {}x{})", w, ht, h ? h->width : 0,
           h ? h->height : 0);
  if (period < 2 || w < 4 * period + 2 || ht < 4 * period + 2)
    fail("eval", "periodic trace: a {}x{} grid is too small for period {}", w, ht, period);
  // Profiles of the squared curvature over whole periods of interior cells; their power spectra (and
  // folded profiles) are averaged over the rasters before the peak is read, so independent
  // realisations (seeds) average the noise around the peak and keep a ripple they share.
  const int nx = (w - 2) / period * period, ny = (ht - 2) / period * period;
  PeriodicTrace t;
  for (int axis = 0; axis < 2; ++axis) {
    const int n = axis == 0 ? nx : ny;
    const int bin = n / period;
    std::vector<double> power(size_t(n / 2 + 1), 0.0), fold(size_t(period), 0.0);
    double mean_all = 0;
    for (const Heightfield* hp : hs) {
      const Heightfield& h = *hp;
      std::vector<double> prof(size_t(n), 0.0);
      for (int y = 1; y <= ny; ++y)
        for (int x = 1; x <= nx; ++x) {
          const double c = double(h.at(x - 1, y)) + h.at(x + 1, y) + h.at(x, y - 1) + h.at(x, y + 1) - 4.0 * h.at(x, y);
          prof[size_t(axis == 0 ? x - 1 : y - 1)] += c * c;
        }
      double mean = 0;
      for (double v : prof) mean += v;
      mean /= n;
      mean_all += mean;
      for (int i = 0; i < n; ++i) fold[size_t(i % period)] += prof[size_t(i)] / (n / period);
      std::vector<std::complex<double>> in(prof.size()), out;
      for (int i = 0; i < n; ++i) in[size_t(i)] = prof[size_t(i)] - mean;
      Eigen::FFT<double> fft;
      fft.fwd(out, in);
      for (size_t k = 0; k < power.size(); ++k) power[k] += std::norm(out[k]);
    }
    if (!(mean_all > 0)) continue;
    const auto [lo, hi] = std::minmax_element(fold.begin(), fold.end());
    t.ripple = std::max(t.ripple, (*hi - *lo) / mean_all);
    double others = 0;
    int count = 0;
    for (int k = std::max(1, bin * 2 / 3); k <= std::min(n / 2, bin * 3 / 2); ++k)
      if (k != bin) others += power[size_t(k)], ++count;
    if (count > 0 && others > 0) t.peak = std::max(t.peak, power[size_t(bin)] / (others / count));
  }
  return t;
}

EncodeReport encode_report(const Heightfield& h, int sparsity, int atoms, int patch, int iterations,
                           const Progress& progress) {
  require_finite(h, "dictionary", "input");
  if (patch < 4 || patch % 2) fail("dictionary", "patch size must be even and >= 4 (got {})", patch);
  // Patches spaced P/2 (the paper's t0 = n K / 4); a P/4 mirror margin lets the discs cover the corners.
  const int pad = patch / 4;
  Heightfield g(h.width + 2 * pad, h.height + 2 * pad);
  g.georef = h.georef;
  auto mirror = [](int i, int n) {
    if (i < 0) i = -i;
    if (i >= n) i = 2 * n - 2 - i;
    return clampi(i, n);
  };
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) g.at(x, y) = h.at(mirror(x - pad, h.width), mirror(y - pad, h.height));
  std::vector<float> means;
  std::vector<std::pair<int, int>> pos;
  const MatrixF F = extract_patches(g, patch, patch / 2, &means, &pos);
  KsvdOptions k;
  k.atoms = atoms;
  k.sparsity = sparsity;
  k.iterations = iterations;
  const KsvdResult r = learn_ksvd(F, k, scaled_progress(progress, 0, 0.9));
  const SparseCodes codes = batch_omp(r.D, F, sparsity);
  const Heightfield rec = blend_patches(g.width, g.height, patch, decode(r.D, codes), means, pos);
  double acc = 0;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const double d = rec.at(x + pad, y + pad) - h.at(x, y);
      acc += d * d;
    }
  EncodeReport e;
  e.sparsity = sparsity;
  e.atoms = int(r.D.cols());
  e.patch = patch;
  e.patches = int(F.cols());
  e.rmse = std::sqrt(acc / double(h.size()));
  const HeightStats st = compute_stats(h);
  e.psnr = 20 * std::log10((st.max - st.min) / std::max(1e-12, e.rmse));
  e.rho = (double(patch) * patch * e.atoms + double(e.patches) * (2 * sparsity + 2) + 1) / double(h.size());
  report_progress(progress, "dictionary", 1.0, "encoded");
  return e;
}

}  // namespace terracl
