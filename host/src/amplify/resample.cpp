// SPDX-License-Identifier: Apache-2.0
// Block means, bicubic upsampling and the block-mean bias correction (gradient paper, section 5.3).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <algorithm>
#include <array>
#include <deque>
#include <string>
#include <cmath>

#include "amplify/simd_clones.hpp"

namespace terracl {

namespace {

// Upsampling by f with cell-centre alignment (output cell X samples the input at (X + 0.5) / f - 0.5)
// as a table of `taps` weights per phase: output X = sum_j w[phase][j] low[X / f + base[phase] + j].
struct UpTable {
  int f = 1, taps = 0;
  bool mirror = false;                  // edges: half-sample mirror (long kernels) or clamp (bicubic)
  std::vector<int> base;                // per phase: offset of the first tap relative to X / f
  std::vector<float> w;                 // per phase, `taps` weights
  const float* weights(int ph) const { return w.data() + size_t(ph) * taps; }
};

// Catmull-Rom (a = -0.5), 4 taps, clamped edges: the baseline.
UpTable cubic_table(int f) {
  UpTable t;
  t.f = f, t.taps = 4;
  t.base.resize(size_t(f));
  t.w.resize(size_t(f) * 4);
  for (int ph = 0; ph < f; ++ph) {
    const double src = (ph + 0.5) / f - 0.5;
    const int i = int(std::floor(src));
    const double x = src - i;
    t.base[size_t(ph)] = i - 1;
    const double a = -0.5;
    auto k = [a](double d) {
      d = std::fabs(d);
      if (d <= 1) return (a + 2) * d * d * d - (a + 3) * d * d + 1;
      if (d < 2) return a * d * d * d - 5 * a * d * d + 8 * a * d - 4 * a;
      return 0.0;
    };
    for (int j = 0; j < 4; ++j) t.w[size_t(ph) * 4 + j] = float(k(x + 1 - j));
  }
  return t;
}

// Band-limited and consistent: the kernel whose f x f block means reproduce the input for every
// band-limited signal, K(t) = 1/pi int_0^pi cos(w t) / B(w) dw with B(w) = sin(w/2) / (f sin(w/(2f)))
// the response of the f-cell box (t in input cells). An ideal band-limited interpolant is
// statistically the same at every phase (no knots: its curvature has no peak at the cell centres,
// unlike any piecewise polynomial). Truncated to 2R taps with a Lanczos window; the bias correction
// removes the small remaining inconsistency.
UpTable bandlimited_table(int f, int R) {
  UpTable t;
  t.f = f, t.taps = 2 * R, t.mirror = true;
  t.base.resize(size_t(f));
  t.w.resize(size_t(f) * t.taps);
  constexpr int kSteps = 4096;  // midpoint rule over (0, pi)
  std::vector<double> om(kSteps), inv_b(kSteps);
  for (int k = 0; k < kSteps; ++k) {
    om[size_t(k)] = M_PI * (k + 0.5) / kSteps;
    inv_b[size_t(k)] = f * std::sin(om[size_t(k)] / (2 * f)) / std::sin(om[size_t(k)] / 2);
  }
  auto sinc = [](double x) { return x == 0 ? 1.0 : std::sin(M_PI * x) / (M_PI * x); };
  for (int ph = 0; ph < f; ++ph) {
    const double src = (ph + 0.5) / f - 0.5;
    const int i = int(std::floor(src));
    t.base[size_t(ph)] = i - R + 1;
    for (int j = 0; j < t.taps; ++j) {
      const double d = src - (i - R + 1 + j);  // distance to the tap's cell centre
      double k = 0;
      for (int q = 0; q < kSteps; ++q) k += std::cos(om[size_t(q)] * d) * inv_b[size_t(q)];
      k /= kSteps;
      k *= std::fabs(d) < R ? sinc(d / R) : 0.0;
      t.w[size_t(ph) * t.taps + j] = float(k);
    }
    // The window breaks the kernel's moments: the least change w + a + b d restoring sum w = 1 and
    // sum w d = 0 (constants and linear ramps reproduced exactly).
    double s0 = 0, s1 = 0, sd = 0, sdd = 0;
    for (int j = 0; j < t.taps; ++j) {
      const double d = src - (i - R + 1 + j), w = t.w[size_t(ph) * t.taps + j];
      s0 += w, s1 += w * d, sd += d, sdd += d * d;
    }
    const double n = t.taps, det = n * sdd - sd * sd;
    const double a = ((1 - s0) * sdd - (0 - s1) * sd) / det, b = (n * (0 - s1) - sd * (1 - s0)) / det;
    for (int j = 0; j < t.taps; ++j) {
      const double d = src - (i - R + 1 + j);
      t.w[size_t(ph) * t.taps + j] = float(t.w[size_t(ph) * t.taps + j] + a + b * d);
    }
  }
  return t;
}

// Taps of the band-limited base: R = 8 input cells each side (R 2-8 measured in docs/amplify.md:
// shorter kernels leave a block-period trace, R 3-4 also a patch-spacing one).
constexpr int kBandRadius = 8;

const UpTable& table_for(const std::string& base, int f) {
  // Small per-(base, f) cache: the band-limited table costs ~f R 4096 cosines.
  static thread_local std::deque<std::pair<std::pair<std::string, int>, UpTable>> cache;  // stable references
  for (const auto& e : cache)
    if (e.first.first == base && e.first.second == f) return e.second;
  if (base != "bicubic" && base != "bandlimited") fail("amplify", "base '{}' is not one of bicubic|bandlimited", base);
  cache.push_back({{base, f}, base == "bicubic" ? cubic_table(f) : bandlimited_table(f, kBandRadius)});
  return cache.back().second;
}

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }
// Half-sample mirror, periodic with 2n (kernels longer than the grid reflect again).
inline int mirrori(int i, int n) {
  const int p = 2 * n;
  i %= p;
  if (i < 0) i += p;
  return i < n ? i : p - 1 - i;
}
inline int edge(const UpTable& t, int i, int n) { return t.mirror ? mirrori(i, n) : clampi(i, n); }

constexpr int kMaxTaps = 2 * kBandRadius;


// out[i] = sum_j w[j] src[j][i0 + i] for i in [0, m), the taps added in order j = 0..n-1 (as a loop
// of whole-row passes would), 16 columns at a time held in registers (independent sums hide the
// adds' latency).
TERRACL_SIMD_CLONES void fir_columns(const float* const* src, const float* w, int n, int i0, int m, float* out) {
  constexpr int kLanes = 16;
  int i = 0;
  for (; i + kLanes <= m; i += kLanes) {
    float s[kLanes] = {};
    for (int j = 0; j < n; ++j) {
      const float wj = w[j], *x = src[j] + i0 + i;
      for (int q = 0; q < kLanes; ++q) s[q] += wj * x[q];
    }
    for (int q = 0; q < kLanes; ++q) out[i + q] = s[q];
  }
  for (; i < m; ++i) {
    float s = 0;
    for (int j = 0; j < n; ++j) s += w[j] * src[j][i0 + i];
    out[i] = s;
  }
}

// One output row Y of upsample(low) over the output columns [X0, X0 + w): the vertical pass over the
// input columns [lo, hi) the taps reach (edges resolved once per row, not per tap), then the
// horizontal pass phase by phase: the columns X = f k + ph share their weights, so each phase is a
// short FIR over `row` that vectorises over k (each sum still adds its taps in order j = 0..n-1, so
// the result is the same as a per-column loop). `row` is scratch of hi - lo floats, `acc` of at least
// w / f + 1.
void upsample_row(const UpTable& t, const Heightfield& low, int Y, int X0, int w, int lo, int hi, float* row,
                  float* acc, float* o, bool add, float scale) {
  const int f = t.f, n = t.taps, lw = low.width;
  const int py = Y % f, by = Y / f + t.base[size_t(py)];
  const float* wy = t.weights(py);
  const int in0 = std::max(lo, 0), in1 = std::min(hi, lw);  // columns inside the input
  const float* src[kMaxTaps];
  for (int j = 0; j < n; ++j) src[j] = low.z.data() + size_t(edge(t, by + j, low.height)) * lw;
  fir_columns(src, wy, n, in0, in1 - in0, row + (in0 - lo));
  for (int i = lo; i < hi; ++i)  // columns outside the input: their edge images
    if (i < 0 || i >= lw) row[i - lo] = row[edge(t, i, lw) - lo];
  for (int ph = 0; ph < f; ++ph) {
    // Output columns X0 <= f k + ph < X0 + w.
    const int k0 = (X0 - ph + f - 1 >= 0 ? (X0 - ph + f - 1) / f : -((ph - X0) / f));
    const int k1 = (X0 + w - ph + f - 1) / f;
    if (k1 <= k0) continue;
    const int m = k1 - k0;
    const float* wx = t.weights(ph);
    const float* r = row + (k0 + t.base[size_t(ph)] - lo);
    const float* taps[kMaxTaps];
    for (int j = 0; j < n; ++j) taps[j] = r + j;
    fir_columns(taps, wx, n, 0, m, acc);
    float* dst = o + (size_t(k0) * f + ph - X0);
    if (add)
      for (int k = 0; k < m; ++k) dst[size_t(k) * f] += scale * acc[k];
    else
      for (int k = 0; k < m; ++k) dst[size_t(k) * f] = scale * acc[k];
  }
}

// Input columns [lo, hi) the output columns [X0, X0 + w) reach (their edge images included).
std::pair<int, int> reach(const UpTable& t, const Heightfield& low, int X0, int w) {
  int lo = X0 / t.f + *std::min_element(t.base.begin(), t.base.end());
  int hi = (X0 + w - 1) / t.f + *std::max_element(t.base.begin(), t.base.end()) + t.taps;
  for (int i = lo; i < hi; ++i) {
    const int e = edge(t, i, low.width);
    lo = std::min(lo, e), hi = std::max(hi, e + 1);
  }
  return {lo, hi};
}

// out(X, Y) (+)= upsampled(low)(X, Y) for every output cell, row by row (no full-size temporary).
void upsample_into(const UpTable& t, const Heightfield& low, Heightfield& out, bool add, float scale = 1.f) {
  const auto [lo, hi] = reach(t, low, 0, out.width);
  parallel_for(size_t(out.height), 0, [&](size_t y0, size_t y1) {
    std::vector<float> row(static_cast<size_t>(hi - lo)), acc(size_t(out.width / t.f + 2));
    for (size_t Y = y0; Y < y1; ++Y)
      upsample_row(t, low, int(Y), 0, out.width, lo, hi, row.data(), acc.data(), out.z.data() + Y * size_t(out.width),
                   add, scale);
  });
}

// The window [X0, X0 + w) x [Y0, Y0 + h) of upsample(low), row-major into out.
void upsample_window_into(const UpTable& t, const Heightfield& low, int X0, int Y0, int w, int h, float* out) {
  const auto [lo, hi] = reach(t, low, X0, w);
  std::vector<float> row(static_cast<size_t>(hi - lo)), acc(size_t(w / t.f + 2));
  for (int Y = Y0; Y < Y0 + h; ++Y)
    upsample_row(t, low, Y, X0, w, lo, hi, row.data(), acc.data(), out + size_t(Y - Y0) * w, false, 1.f);
}

void bicubic_into(const Heightfield& low, int f, Heightfield& out, bool add, float scale = 1.f) {
  upsample_into(table_for("bicubic", f), low, out, add, scale);
}

}  // namespace

Heightfield block_mean(const Heightfield& h, int f) {
  if (f < 1) fail("amplify", "block factor must be >= 1 (got {})", f);
  const int w = h.width / f, hh = h.height / f;
  if (w < 1 || hh < 1) fail("amplify", "a {}x{} grid has no complete {}x{} block", h.width, h.height, f, f);
  Heightfield out(w, hh);
  out.georef = h.georef.resampled(1.0 / f);
  out.metadata = h.metadata;
  parallel_for(size_t(hh), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        double s = 0;
        for (int v = 0; v < f; ++v) {
          const float* r = h.z.data() + (y * f + v) * size_t(h.width) + size_t(x) * f;
          for (int u = 0; u < f; ++u) s += r[u];
        }
        out.at(x, int(y)) = float(s / (f * f));
      }
  });
  return out;
}

Heightfield bicubic_upsample(const Heightfield& h, int f) {
  if (f < 1) fail("amplify", "upsampling factor must be >= 1 (got {})", f);
  Heightfield out(h.width * f, h.height * f);
  out.georef = h.georef.resampled(f);
  out.metadata = h.metadata;
  bicubic_into(h, f, out, false);
  return out;
}

void add_bicubic(Heightfield& out, const Heightfield& low, int f, float scale) { bicubic_into(low, f, out, true, scale); }

Heightfield upsample(const Heightfield& h, int f, const std::string& base) {
  if (f < 1) fail("amplify", "upsampling factor must be >= 1 (got {})", f);
  Heightfield out(h.width * f, h.height * f);
  out.georef = h.georef.resampled(f);
  out.metadata = h.metadata;
  upsample_into(table_for(base, f), h, out, false);
  return out;
}

void add_upsampled(Heightfield& out, const Heightfield& low, int f, float scale, const std::string& base) {
  upsample_into(table_for(base, f), low, out, true, scale);
}

void upsample_window(const Heightfield& low, int f, const std::string& base, int X0, int Y0, int w, int h, float* out) {
  upsample_window_into(table_for(base, f), low, X0, Y0, w, h, out);
}

int upsample_reach(int f, const std::string& base) {
  const UpTable& t = table_for(base, f);
  int r = 0;
  for (int b : t.base) r = std::max({r, -b, b + t.taps - 1});
  return r + 1;
}

MatrixF smooth_part_operator(int n, int f, const std::string& base) {
  if (f < 1 || n % f) fail("amplify", "smooth part: {} cells are not whole blocks of {}", n, f);
  const int m = n / f;
  const UpTable& t = table_for(base, f);
  MatrixF up = MatrixF::Zero(n, m), mean = MatrixF::Zero(m, n);
  for (int X = 0; X < n; ++X) {
    const int ph = X % f, b = X / f + t.base[size_t(ph)];
    for (int j = 0; j < t.taps; ++j) up(X, edge(t, b + j, m)) += t.weights(ph)[j];
  }
  for (int x = 0; x < m; ++x)
    for (int u = 0; u < f; ++u) mean(x, x * f + u) = 1.f / f;
  return up * mean;
}

void correct_block_means(Heightfield& high, const Heightfield& low, int f, int smooth_passes, const std::string& base) {
  if (high.width != low.width * f || high.height != low.height * f)
    fail("amplify", "bias correction: {}x{} is not {} times {}x{}", high.width, high.height, f, low.width, low.height);
  Heightfield r(low.width, low.height);
  auto residual = [&] {
    const Heightfield m = block_mean(high, f);
    for (size_t i = 0; i < r.z.size(); ++i) r.z[i] = low.z[i] - m.z[i];
  };
  // Back-projection with a smooth (bicubic) spread of the block residuals: converges towards the
  // block means without the staircase a constant per-block shift would add...
  const UpTable& t = table_for(base, f);
  for (int p = 0; p < smooth_passes; ++p) {
    residual();
    upsample_into(t, r, high, true);
  }
  // ...and a final constant shift per block makes them exact.
  residual();
  parallel_for(size_t(high.height), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < high.width; ++x) high.z[y * size_t(high.width) + x] += r.at(x / f, int(y) / f);
  });
}

}  // namespace terracl
