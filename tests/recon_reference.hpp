// SPDX-License-Identifier: Apache-2.0
#pragma once
// Independent CPU references for the gradient/reconstruction tests: the 5-point Neumann
// Laplacian in double and a sparse direct solve (Eigen) of the constrained Poisson problem.
#include <terracl/heightfield.hpp>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include <cmath>
#include <vector>

namespace terracl::test {

/// f = sum over in-grid neighbours (h_n - h) / d^2, in double.
inline std::vector<double> laplacian(const std::vector<double>& h, int W, int H, double cx, double cy) {
  std::vector<double> f(h.size(), 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      double s = 0;
      if (x > 0) s += (h[i - 1] - h[i]) / (cx * cx);
      if (x + 1 < W) s += (h[i + 1] - h[i]) / (cx * cx);
      if (y > 0) s += (h[i - W] - h[i]) / (cy * cy);
      if (y + 1 < H) s += (h[i + W] - h[i]) / (cy * cy);
      f[i] = s;
    }
  return f;
}

/// Solves laplacian(h) = f at free cells, h = fixed at cells where fixed is not NaN (at least one
/// fixed cell). Double precision, Eigen SimplicialLDLT on -L restricted to the free cells.
inline std::vector<double> direct_solve(const std::vector<double>& f, const std::vector<float>& fixed, int W, int H,
                                        double cx, double cy) {
  const size_t N = size_t(W) * H;
  std::vector<int> id(N, -1);
  int n = 0;
  for (size_t i = 0; i < N; ++i)
    if (std::isnan(fixed[i])) id[i] = n++;
  std::vector<Eigen::Triplet<double>> t;
  Eigen::VectorXd b(n);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      if (id[i] < 0) continue;
      double diag = 0, rhs = -f[i];
      auto nb = [&](bool ok, size_t j, double w) {
        if (!ok) return;
        diag += w;
        if (id[j] >= 0) t.emplace_back(id[i], id[j], -w);
        else rhs += w * fixed[j];
      };
      nb(x > 0, i - 1, 1 / (cx * cx));
      nb(x + 1 < W, i + 1, 1 / (cx * cx));
      nb(y > 0, i - W, 1 / (cy * cy));
      nb(y + 1 < H, i + W, 1 / (cy * cy));
      t.emplace_back(id[i], id[i], diag);
      b(id[i]) = rhs;
    }
  std::vector<double> h(N);
  if (n > 0) {
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
    const Eigen::VectorXd v = ldlt.solve(b);
    for (size_t i = 0; i < N; ++i) h[i] = id[i] >= 0 ? v(id[i]) : fixed[i];
  } else {
    for (size_t i = 0; i < N; ++i) h[i] = fixed[i];
  }
  return h;
}

inline double max_abs_diff(const std::vector<float>& a, const std::vector<double>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(double(a[i]) - b[i]));
  return m;
}

inline double range_of(const std::vector<double>& v) {
  double lo = 1e300, hi = -1e300;
  for (double x : v) lo = std::min(lo, x), hi = std::max(hi, x);
  return hi - lo;
}

}  // namespace terracl::test
