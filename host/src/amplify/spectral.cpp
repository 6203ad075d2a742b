// The HF energy a finer grid of the input's terrain should have, from the input's own spectrum
// (issue 16: detail calibrated per input, not only on the exemplar's average).
#include <terracl/amplify.hpp>

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>

namespace terracl {

double predicted_energy_above(const Heightfield& low, int f) {
  const int w = low.width, h = low.height;
  if (f < 2 || w < 16 || h < 16) return -1;
  // The evaluation's windowing (spectrum_above): plane removed, 2-D Hann window.
  double sz = 0, sxz = 0, syz = 0, sxx = 0, syy = 0;
  const double cx = 0.5 * (w - 1), cy = 0.5 * (h - 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double z = low.at(x, y), dx = x - cx, dy = y - cy;
      sz += z, sxz += dx * z, syz += dy * z, sxx += dx * dx, syy += dy * dy;
    }
  const double a = sz / (double(w) * h), b = sxx > 0 ? sxz / sxx : 0, c = syy > 0 ? syz / syy : 0;
  std::vector<std::complex<double>> grid(size_t(w) * h), in, out;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double win = (0.5 - 0.5 * std::cos(2 * M_PI * (x + 0.5) / w)) * (0.5 - 0.5 * std::cos(2 * M_PI * (y + 0.5) / h));
      grid[size_t(y) * w + x] = win * (low.at(x, y) - a - b * (x - cx) - c * (y - cy));
    }
  Eigen::FFT<double> fft;
  for (int y = 0; y < h; ++y) {
    in.assign(grid.begin() + size_t(y) * w, grid.begin() + size_t(y + 1) * w);
    fft.fwd(out, in);
    std::copy(out.begin(), out.end(), grid.begin() + size_t(y) * w);
  }
  // The input is the block mean of the terrain: its spectrum is the terrain's times the f-cell box's
  // response B(nu) = sin(pi f nu) / (f sin(pi nu)) per axis (nu in cycles per fine cell), undone here.
  auto box = [f](double nu_coarse) {
    const double nu = nu_coarse / f;
    return nu == 0 ? 1.0 : std::sin(M_PI * f * nu) / (f * std::sin(M_PI * nu));
  };
  // Radially averaged power in 8 log-spaced shells over the octave below the input's Nyquist (0.25 to
  // 0.5 cycles per input cell): the mean power per shell (not the mean log power, which is biased low
  // by Euler's constant for exponentially distributed periodogram values).
  constexpr int kShells = 8;
  std::vector<double> psum(kShells, 0.0), lksum(kShells, 0.0), cnt(kShells, 0.0);
  in.resize(size_t(h));
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < h; ++y) in[size_t(y)] = grid[size_t(y) * w + x];
    fft.fwd(out, in);
    const double fx = double(x <= w / 2 ? x : x - w) / w;
    for (int y = 0; y < h; ++y) {
      const double fy = double(y <= h / 2 ? y : y - h) / h, k = std::hypot(fx, fy);
      if (k < 0.25 || k >= 0.5) continue;
      const int s = std::min(kShells - 1, int(std::log2(k / 0.25) * kShells));
      const double bb = box(fx) * box(fy);
      psum[size_t(s)] += std::norm(out[size_t(y)]) / std::max(1e-6, bb * bb);
      lksum[size_t(s)] += std::log(k);
      cnt[size_t(s)] += 1;
    }
  }
  // Least-squares line log P = lA + beta log k through the shells.
  double n = 0, sx = 0, sy = 0, sxy = 0, sxx2 = 0;
  for (int s = 0; s < kShells; ++s) {
    if (cnt[size_t(s)] < 1 || !(psum[size_t(s)] > 0)) continue;
    const double lx = lksum[size_t(s)] / cnt[size_t(s)], ly = std::log(psum[size_t(s)] / cnt[size_t(s)]);
    n += 1, sx += lx, sy += ly, sxy += lx * ly, sxx2 += lx * lx;
  }
  const double den = n * sxx2 - sx * sx;
  if (n < 4 || !(den > 0)) return -1;
  const double beta = (n * sxy - sx * sy) / den, la = (sy - beta * sx) / n;
  // Extrapolated over the bins of the f times finer grid above the input's Nyquist. At one physical
  // frequency, the periodogram of the fine grid (f^2 times the cells, each 1/f^2 the area) is f^4
  // times the coarse one's.
  const int W = w * f, H = h * f;
  const double nyq = 0.5 / f;
  double e = 0;
  for (int Y = 0; Y < H; ++Y) {
    const double gy = double(Y <= H / 2 ? Y : Y - H) / H;
    for (int X = 0; X < W; ++X) {
      const double gx = double(X <= W / 2 ? X : X - W) / W;
      if (std::fabs(gx) <= nyq && std::fabs(gy) <= nyq) continue;
      e += std::exp(la + beta * std::log(f * std::hypot(gx, gy)));
    }
  }
  e *= double(f) * f * f * f;
  return std::isfinite(e) && e > 0 ? e : -1;
}

}  // namespace terracl
