// SPDX-License-Identifier: Apache-2.0
// The HF energy a finer grid of the input's terrain should have, from the input's own spectrum
// (detail calibrated per input, not only on the exemplar's average).
#include <terracl/amplify.hpp>

#include "row_spectra.hpp"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>

namespace terracl {

double predicted_energy_above(const Heightfield& low, int f) {
  const int w = low.width, h = low.height;
  if (f < 2 || w < 16 || h < 16) return -1;
  // The evaluation's windowing (spectrum_above): plane removed, 2-D Hann window.
  const std::vector<std::complex<double>> grid = windowed_row_spectra(low);
  // The input is the block mean of the terrain: its spectrum at (fx, fy) (cycles per input cell) is
  // the terrain's times the f-cell box's response B(u) = sin(pi u) / (f sin(pi u / f)) per axis, plus
  // the aliases (fx + mx, fy + my) of the finer frequencies folded onto it (|fx + mx| < f / 2). The
  // model A |k|^beta is fitted through all of them: dividing by B^2 alone ignored the aliases and
  // over-predicted a beta = -3 power law by 1.3 x.
  auto box2 = [f](double u) {
    const double b = u == 0 ? 1.0 : std::sin(M_PI * u) / (f * std::sin(M_PI * u / f));
    return b * b;
  };
  // Radially averaged power in 8 log-spaced shells over the octave below the input's Nyquist (0.25 to
  // 0.5 cycles per input cell): the mean power per shell (not the mean log power, which is biased low
  // by Euler's constant for exponentially distributed periodogram values). Each bin keeps its aliases'
  // log |k| and B^2 for the model.
  constexpr int kShells = 8;
  const int na = f / 2;  // aliases -na..na per axis
  const int nal = (2 * na + 1) * (2 * na + 1);
  std::vector<double> psum(kShells, 0.0), cnt(kShells, 0.0);
  std::vector<int> bin_shell;
  std::vector<double> alias_logk, alias_w;
  // Columns in parallel, each into its own lists, then joined and summed in column order (as one
  // serial loop would).
  struct Column {
    std::vector<int> shell;
    std::vector<double> power, logk, weight;
  };
  std::vector<Column> cols(static_cast<size_t>(w));
  parallel_for(size_t(w), 0, [&](size_t c0, size_t c1) {
    Eigen::FFT<double> fft;
    std::vector<std::complex<double>> in(static_cast<size_t>(h)), out;
    for (size_t x = c0; x < c1; ++x) {
      Column& col = cols[x];
      for (int y = 0; y < h; ++y) in[size_t(y)] = grid[size_t(y) * w + x];
      fft.fwd(out, in);
      const double fx = double(int(x) <= w / 2 ? int(x) : int(x) - w) / w;
      for (int y = 0; y < h; ++y) {
        const double fy = double(y <= h / 2 ? y : y - h) / h, k = std::hypot(fx, fy);
        if (k < 0.25 || k >= 0.5) continue;
        col.shell.push_back(std::min(kShells - 1, int(std::log2(k / 0.25) * kShells)));
        col.power.push_back(std::norm(out[size_t(y)]));
        for (int my = -na; my <= na; ++my)
          for (int mx = -na; mx <= na; ++mx) {
            const double ux = fx + mx, uy = fy + my, ka = std::hypot(ux, uy);
            const bool inside = std::fabs(ux) < 0.5 * f && std::fabs(uy) < 0.5 * f && ka > 0;
            col.logk.push_back(inside ? std::log(ka) : 0.0);
            col.weight.push_back(inside ? box2(ux) * box2(uy) : 0.0);
          }
      }
    }
  });
  for (const Column& col : cols) {
    for (size_t b = 0; b < col.shell.size(); ++b)
      psum[size_t(col.shell[b])] += col.power[b], cnt[size_t(col.shell[b])] += 1;
    bin_shell.insert(bin_shell.end(), col.shell.begin(), col.shell.end());
    alias_logk.insert(alias_logk.end(), col.logk.begin(), col.logk.end());
    alias_w.insert(alias_w.end(), col.weight.begin(), col.weight.end());
  }
  std::vector<double> lp;  // log mean power per non-empty shell
  std::vector<int> shells;
  for (int s = 0; s < kShells; ++s)
    if (cnt[size_t(s)] > 0 && psum[size_t(s)] > 0) shells.push_back(s), lp.push_back(std::log(psum[size_t(s)] / cnt[size_t(s)]));
  if (shells.size() < 4) return -1;
  // For a given beta: the model's mean per shell, the best log A (mean log ratio) and the residual.
  // The bins' sums in parallel (the exponentials are most of the calibration's time), added to their
  // shells in bin order, as a serial loop would.
  std::vector<double> bin_m(bin_shell.size());
  auto fit = [&](double beta, double* la) {
    parallel_for(bin_shell.size(), 0, [&](size_t b0, size_t b1) {
      for (size_t b = b0; b < b1; ++b) {
        double m = 0;
        for (int a = 0; a < nal; ++a) {
          const size_t i = b * size_t(nal) + size_t(a);
          if (alias_w[i] > 0) m += alias_w[i] * std::exp(beta * alias_logk[i]);
        }
        bin_m[b] = m;
      }
    });
    std::vector<double> msum(kShells, 0.0);
    for (size_t b = 0; b < bin_shell.size(); ++b) msum[size_t(bin_shell[b])] += bin_m[b];
    std::vector<double> r;
    double mean = 0;
    for (size_t j = 0; j < shells.size(); ++j) {
      const int s = shells[j];
      r.push_back(lp[j] - std::log(std::max(1e-300, msum[size_t(s)] / cnt[size_t(s)])));
      mean += r.back();
    }
    mean /= double(r.size());
    double res = 0;
    for (double v : r) res += (v - mean) * (v - mean);
    if (la) *la = mean;
    return res;
  };
  // Golden-section search for beta in [-7, -0.5] (terrain: about -4 to -2).
  double lo = -7, hi = -0.5;
  const double gr = 0.5 * (std::sqrt(5.0) - 1);
  double c1 = hi - gr * (hi - lo), c2 = lo + gr * (hi - lo), r1 = fit(c1, nullptr), r2 = fit(c2, nullptr);
  for (int it = 0; it < 30; ++it) {
    if (r1 < r2) hi = c2, c2 = c1, r2 = r1, c1 = hi - gr * (hi - lo), r1 = fit(c1, nullptr);
    else lo = c1, c1 = c2, r1 = r2, c2 = lo + gr * (hi - lo), r2 = fit(c2, nullptr);
  }
  const double beta = 0.5 * (lo + hi);
  double la = 0;
  fit(beta, &la);
  if (!std::isfinite(la)) return -1;
  // Extrapolated over the bins of the f times finer grid above the input's Nyquist. At one physical
  // frequency, the periodogram of the fine grid (f^2 times the cells, each 1/f^2 the area) is f^4
  // times the coarse one's.
  const int W = w * f, H = h * f;
  const double nyq = 0.5 / f;
  // The terms in parallel, summed in row order (as one serial loop would).
  std::vector<double> terms(size_t(W) * H, 0.0);
  std::vector<char> above(terms.size(), 0);
  parallel_for(size_t(H), 0, [&](size_t y0, size_t y1) {
    for (int Y = int(y0); Y < int(y1); ++Y) {
      const double gy = double(Y <= H / 2 ? Y : Y - H) / H;
      for (int X = 0; X < W; ++X) {
        const double gx = double(X <= W / 2 ? X : X - W) / W;
        if (std::fabs(gx) <= nyq && std::fabs(gy) <= nyq) continue;
        const size_t i = size_t(Y) * W + X;
        terms[i] = std::exp(la + beta * std::log(f * std::hypot(gx, gy)));
        above[i] = 1;
      }
    }
  });
  double e = 0;
  for (size_t i = 0; i < terms.size(); ++i)
    if (above[i]) e += terms[i];
  e *= double(f) * f * f * f;
  return std::isfinite(e) && e > 0 ? e : -1;
}

}  // namespace terracl
