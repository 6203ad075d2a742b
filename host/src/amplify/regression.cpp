// SPDX-License-Identifier: Apache-2.0
// Faithful amplification: a linear regression of each f x f output block from the input's
// (2r+1)^2 neighbourhood around its cell, learned on the exemplar (its block means as input, itself
// as target), one regression per class of local gradient direction. It is the least-squares
// estimate of the high-resolution terrain given the low one among linear filters, so it can only
// beat bicubic (a fixed linear filter in the same span) on terrain like the exemplar's.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace terracl {

namespace {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

// The input's neighbourhood of cell (x, y) minus the cell itself (the centre, always 0, is left
// out): heights relative to the cell make the regression independent of the absolute elevation.
void features(const Heightfield& low, int x, int y, int r, float* out) {
  const float c = low.at(x, y);
  int k = 0;
  for (int v = -r; v <= r; ++v)
    for (int u = -r; u <= r; ++u)
      if (u != 0 || v != 0) out[k++] = low.at(clampi(x + u, low.width), clampi(y + v, low.height)) - c;
}

// Class of cell (x, y): the direction of the input's gradient (central differences over the 3 x 3
// neighbourhood), folded to [0, pi) and cut into `classes` sectors; flat cells go to class 0.
int direction_class(const Heightfield& low, int x, int y, int classes) {
  if (classes <= 1) return 0;
  auto z = [&](int u, int v) { return double(low.at(clampi(x + u, low.width), clampi(y + v, low.height))); };
  const double gx = (z(1, -1) + 2 * z(1, 0) + z(1, 1)) - (z(-1, -1) + 2 * z(-1, 0) + z(-1, 1));
  const double gy = (z(-1, 1) + 2 * z(0, 1) + z(1, 1)) - (z(-1, -1) + 2 * z(0, -1) + z(1, -1));
  if (!(std::hypot(gx, gy) > 0)) return 0;
  double a = std::atan2(gy, gx);
  if (a < 0) a += M_PI;
  return std::min(classes - 1, int(a / M_PI * classes));
}

}  // namespace

int BlockRegression::features_count() const { return (2 * radius + 1) * (2 * radius + 1) - 1; }

long regression_samples(const std::vector<Heightfield>& exemplars, int f, int radius) {
  long n = 0;
  for (const Heightfield& ex : exemplars) {
    if (f < 1 || ex.width < 4 * f || ex.height < 4 * f) continue;
    n += long(std::max(0, ex.width / f - 2 * radius)) * std::max(0, ex.height / f - 2 * radius);
  }
  return n;
}

BlockRegression learn_block_regression(const std::vector<Heightfield>& exemplars, int f, int radius, int classes,
                                       double ridge) {
  if (f < 2) fail("amplify", "faithful mode: factor {} must be >= 2", f);
  if (radius < 1 || radius > 4) fail("amplify", "faithful mode: neighbourhood radius {} is not in [1, 4]", radius);
  if (classes < 1 || classes > 64) fail("amplify", "faithful mode: {} direction classes is not in [1, 64]", classes);
  BlockRegression g;
  g.factor = f;
  g.radius = radius;
  g.classes = classes;
  const int n = g.features_count(), m = f * f;
  // Normal equations per class, and pooled over every class (the fallback of sparse classes).
  std::vector<Eigen::MatrixXd> ata(size_t(classes) + 1, Eigen::MatrixXd::Zero(n, n)),
      atb(size_t(classes) + 1, Eigen::MatrixXd::Zero(n, m));
  std::vector<long> count(size_t(classes) + 1, 0);
  std::vector<float> phi(static_cast<size_t>(n));
  Eigen::VectorXd a(n), b(m);
  for (const Heightfield& ex : exemplars) {
    if (ex.width < 4 * f || ex.height < 4 * f) continue;
    const Heightfield low = block_mean(ex, f);
    // Cells whose neighbourhood lies inside the exemplar (no clamped borders in the training set).
    for (int y = radius; y + radius < low.height; ++y)
      for (int x = radius; x + radius < low.width; ++x) {
        features(low, x, y, radius, phi.data());
        const float c = low.at(x, y);
        for (int k = 0; k < n; ++k) a[k] = phi[size_t(k)];
        for (int v = 0; v < f; ++v)
          for (int u = 0; u < f; ++u) b[v * f + u] = double(ex.at(x * f + u, y * f + v)) - c;
        const int cls = direction_class(low, x, y, classes);
        for (size_t s : {size_t(cls), size_t(classes)}) {
          ata[s].selfadjointView<Eigen::Lower>().rankUpdate(a);
          atb[s] += a * b.transpose();
          ++count[s];
        }
      }
  }
  if (count[size_t(classes)] < 4 * n)
    fail("amplify", "faithful mode: the exemplar holds {} complete {}x{} neighbourhoods at this cell size; it needs {}",
         count[size_t(classes)], 2 * radius + 1, 2 * radius + 1, 4 * n);
  auto solve = [&](size_t s) {
    Eigen::MatrixXd A = ata[s].selfadjointView<Eigen::Lower>();
    // Ridge relative to the mean feature energy: stable for flat exemplars, negligible otherwise.
    const double lambda = ridge * std::max(1e-12, A.trace() / n);
    A.diagonal().array() += lambda;
    return Eigen::MatrixXd(A.ldlt().solve(atb[s]));
  };
  const Eigen::MatrixXd pooled = solve(size_t(classes));
  g.weights.resize(size_t(classes));
  for (int c = 0; c < classes; ++c) {
    // A class seen too rarely to fit its own n x m weights uses the pooled ones.
    const Eigen::MatrixXd w = count[size_t(c)] >= 20 * n ? solve(size_t(c)) : pooled;
    g.weights[size_t(c)] = w.transpose().cast<float>();  // m x n
  }
  g.samples = count[size_t(classes)];
  return g;
}

Heightfield apply_block_regression(const Heightfield& low, const BlockRegression& g, int threads) {
  const int f = g.factor, n = g.features_count();
  Heightfield out(low.width * f, low.height * f);
  out.georef = low.georef.resampled(f);
  out.metadata = low.metadata;
  parallel_for(size_t(low.height), threads, [&](size_t y0, size_t y1) {
    VectorF phi(n), block(f * f);
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < low.width; ++x) {
        features(low, x, y, g.radius, phi.data());
        block.noalias() = g.weights[size_t(direction_class(low, x, y, g.classes))] * phi;
        const float c = low.at(x, y);
        for (int v = 0; v < f; ++v)
          for (int u = 0; u < f; ++u) out.at(x * f + u, y * f + v) = c + block[v * f + u];
      }
  });
  return out;
}

}  // namespace terracl
