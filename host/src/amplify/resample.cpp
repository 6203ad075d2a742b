// Block means, bicubic upsampling and the block-mean bias correction (gradient paper, section 5.3).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <array>
#include <cmath>

namespace terracl {

namespace {

// Catmull-Rom weights for the f phases of a cell-centre aligned upsampling by f: output cell X
// samples the input at (X + 0.5) / f - 0.5.
struct CubicTable {
  int f;
  std::vector<int> base;               // per phase: offset of the first tap relative to X / f
  std::vector<std::array<float, 4>> w;  // per phase
};
CubicTable cubic_table(int f) {
  CubicTable t{f, std::vector<int>(f), std::vector<std::array<float, 4>>(f)};
  for (int ph = 0; ph < f; ++ph) {
    const double src = (ph + 0.5) / f - 0.5;
    const int i = int(std::floor(src));
    const double x = src - i;
    t.base[ph] = i - 1;
    const double a = -0.5;
    auto k = [a](double d) {
      d = std::fabs(d);
      if (d <= 1) return (a + 2) * d * d * d - (a + 3) * d * d + 1;
      if (d < 2) return a * d * d * d - 5 * a * d * d + 8 * a * d - 4 * a;
      return 0.0;
    };
    for (int j = 0; j < 4; ++j) t.w[ph][j] = float(k(x + 1 - j));
  }
  return t;
}

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

// out(X, Y) (+)= bicubic(low)(X, Y) for every output cell, row by row (no full-size temporary).
void bicubic_into(const Heightfield& low, int f, Heightfield& out, bool add, float scale = 1.f) {
  const CubicTable t = cubic_table(f);
  const int w = low.width, h = low.height, W = out.width;
  parallel_for(size_t(out.height), 0, [&](size_t y0, size_t y1) {
    std::vector<float> row(static_cast<size_t>(w));
    for (size_t Y = y0; Y < y1; ++Y) {
      const int py = int(Y) % f, by = int(Y) / f + t.base[py];
      for (int x = 0; x < w; ++x) {
        float s = 0;
        for (int j = 0; j < 4; ++j) s += t.w[py][j] * low.at(x, clampi(by + j, h));
        row[size_t(x)] = s;
      }
      float* o = out.z.data() + Y * size_t(W);
      for (int X = 0; X < W; ++X) {
        const int px = X % f, bx = X / f + t.base[px];
        float s = 0;
        for (int j = 0; j < 4; ++j) s += t.w[px][j] * row[size_t(clampi(bx + j, w))];
        o[X] = add ? o[X] + scale * s : scale * s;
      }
    }
  });
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

MatrixF smooth_part_operator(int n, int f) {
  if (f < 1 || n % f) fail("amplify", "smooth part: {} cells are not whole blocks of {}", n, f);
  const int m = n / f;
  const CubicTable t = cubic_table(f);
  MatrixF up = MatrixF::Zero(n, m), mean = MatrixF::Zero(m, n);
  for (int X = 0; X < n; ++X) {
    const int ph = X % f, b = X / f + t.base[ph];
    for (int j = 0; j < 4; ++j) up(X, clampi(b + j, m)) += t.w[ph][j];
  }
  for (int x = 0; x < m; ++x)
    for (int u = 0; u < f; ++u) mean(x, x * f + u) = 1.f / f;
  return up * mean;
}

void correct_block_means(Heightfield& high, const Heightfield& low, int f, int smooth_passes) {
  if (high.width != low.width * f || high.height != low.height * f)
    fail("amplify", "bias correction: {}x{} is not {} times {}x{}", high.width, high.height, f, low.width, low.height);
  Heightfield r(low.width, low.height);
  auto residual = [&] {
    const Heightfield m = block_mean(high, f);
    for (size_t i = 0; i < r.z.size(); ++i) r.z[i] = low.z[i] - m.z[i];
  };
  // Back-projection with a smooth (bicubic) spread of the block residuals: converges towards the
  // block means without the staircase a constant per-block shift would add...
  for (int p = 0; p < smooth_passes; ++p) {
    residual();
    bicubic_into(r, f, high, true);
  }
  // ...and a final constant shift per block makes them exact.
  residual();
  parallel_for(size_t(high.height), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < high.width; ++x) high.z[y * size_t(high.width) + x] += r.at(x / f, int(y) / f);
  });
}

}  // namespace terracl
