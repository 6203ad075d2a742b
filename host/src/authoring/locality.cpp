// SPDX-License-Identifier: Apache-2.0
// Distance transform for the locality of edits: the solve region is every cell within the
// falloff of a changed cell, so it follows a diagonal stroke instead of filling its bounding box.
#include "authoring/locality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace terracl::edit {
namespace {

// 1-D squared distance transform of f (n samples spaced `step` apart): d[q] = min_p f[p] + ((q-p) step)^2.
void dt1(const float* f, float* d, int n, size_t stride, double step, std::vector<int>& v, std::vector<double>& z) {
  const double inf = std::numeric_limits<double>::infinity();
  auto fv = [&](int i) { return double(f[size_t(i) * stride]); };
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (std::isinf(fv(q))) continue;
    const double pq = q * step;
    double s = -inf;
    while (k >= 0) {
      const double pv = v[k] * step;
      s = ((fv(q) + pq * pq) - (fv(v[k]) + pv * pv)) / (2 * (pq - pv));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -inf : s;
    z[k + 1] = inf;
  }
  if (k < 0) {
    for (int q = 0; q < n; ++q) d[size_t(q) * stride] = std::numeric_limits<float>::infinity();
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q * step) ++j;
    const double t = (q - v[j]) * step;
    d[size_t(q) * stride] = float(t * t + fv(v[j]));
  }
}

}  // namespace

std::vector<float> squared_distance(const std::vector<uint8_t>& src, int w, int h, double cx, double cy) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> a(size_t(w) * h), b(size_t(w) * h);
  for (size_t i = 0; i < a.size(); ++i) a[i] = src[i] ? 0.f : inf;
  const int n = std::max(w, h);
  std::vector<int> v(size_t(n) + 1);
  std::vector<double> z(size_t(n) + 2);
  for (int x = 0; x < w; ++x) dt1(a.data() + x, b.data() + x, h, size_t(w), cy, v, z);  // columns
  for (int y = 0; y < h; ++y) dt1(b.data() + size_t(y) * w, a.data() + size_t(y) * w, w, 1, cx, v, z);  // rows
  return a;
}

}  // namespace terracl::edit
