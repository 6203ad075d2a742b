// SPDX-License-Identifier: Apache-2.0
// Batch-OMP (Rubinstein, Zibulevsky, Elad 2008). The projections D^T x of a block of signals are one
// GEMM; each greedy step then costs O(N k) with the Gram matrix instead of O(N K), and the least-squares
// solve on the active set reuses a Cholesky factor grown by one row per step.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <algorithm>
#include <cmath>

namespace terracl {

namespace {
// Above this many atoms the N x N Gram matrix is too large to hold; its columns are computed on demand.
constexpr int kMaxGramAtoms = 4096;
constexpr int kBlock = 256;
}  // namespace

SparseCodes batch_omp(const MatrixF& D, const MatrixF& X, int sparsity, int threads) {
  if (sparsity < 1) fail("omp", "sparsity must be >= 1 (got {})", sparsity);
  if (D.rows() != X.rows()) fail("omp", "signal length {} differs from atom length {}", X.rows(), D.rows());
  const int N = int(D.cols());
  const int s = std::min(sparsity, N);
  const size_t n = size_t(X.cols());
  SparseCodes codes;
  codes.sparsity = sparsity;
  codes.index.assign(n * sparsity, -1);
  codes.coef.assign(n * sparsity, 0.f);
  if (N == 0 || n == 0) return codes;
  const bool full_gram = N <= kMaxGramAtoms;
  MatrixF G;
  if (full_gram) G.noalias() = D.transpose() * D;

  const size_t blocks = (n + kBlock - 1) / kBlock;
  parallel_for(blocks, threads, [&](size_t b0, size_t b1) {
    Eigen::MatrixXd L(s, s);
    Eigen::VectorXd gamma, rhs, w;
    Eigen::VectorXf alpha;
    MatrixF xb(X.rows(), Eigen::Index(kBlock));
    MatrixF Gcols(N, s);  // columns of G for the active set (on demand without a full Gram matrix)
    std::vector<int> I;
    for (size_t b = b0; b < b1; ++b) {
      const size_t c0 = b * kBlock, m = std::min<size_t>(kBlock, n - c0);
      // A full (zero-padded) block and a sequential energy: a signal's code does not depend on its
      // batch (tiled amplify is exact).
      xb.setZero();
      xb.leftCols(Eigen::Index(m)) = X.middleCols(c0, m);
      const MatrixF A = D.transpose() * xb;
      for (size_t c = 0; c < m; ++c) {
        const auto alpha0 = A.col(c);
        double energy = 0;
        for (Eigen::Index i = 0; i < X.rows(); ++i) energy += double(X(i, Eigen::Index(c0 + c))) * X(i, Eigen::Index(c0 + c));
        if (!(energy > 0)) continue;
        alpha = alpha0;
        I.clear();
        L.setZero();
        for (int k = 0; k < s; ++k) {
          int kk = -1;
          float best = 0;
          for (int j = 0; j < N; ++j) {
            const float a = std::fabs(alpha[j]);
            if (a > best && std::find(I.begin(), I.end(), j) == I.end()) best = a, kk = j;
          }
          if (kk < 0 || best <= 1e-5f * std::sqrt(float(energy))) break;
          if (full_gram) Gcols.col(k) = G.col(kk);
          else Gcols.col(k).noalias() = D.transpose() * D.col(kk);
          if (k == 0) {
            L(0, 0) = 1.0;
          } else {
            w.resize(k);
            for (int i = 0; i < k; ++i) w[i] = Gcols(I[i], k);
            L.topLeftCorner(k, k).triangularView<Eigen::Lower>().solveInPlace(w);
            const double d = 1.0 - w.squaredNorm();
            if (d <= 1e-6) break;  // the atom is (numerically) in the span of the active set
            L.row(k).head(k) = w.transpose();
            L(k, k) = std::sqrt(d);
          }
          I.push_back(kk);
          const int a = int(I.size());
          rhs.resize(a);
          for (int i = 0; i < a; ++i) rhs[i] = alpha0[I[i]];
          gamma = L.topLeftCorner(a, a).triangularView<Eigen::Lower>().solve(rhs);
          L.topLeftCorner(a, a).transpose().triangularView<Eigen::Upper>().solveInPlace(gamma);
          for (int i = 0; i < a; ++i) {
            codes.index[(c0 + c) * sparsity + i] = I[i];
            codes.coef[(c0 + c) * sparsity + i] = float(gamma[i]);
          }
          // Residual energy |x|^2 - alpha0_I . gamma: stop once the signal is represented exactly.
          if (energy - rhs.dot(gamma) <= 1e-6 * energy) break;
          alpha = alpha0 - Gcols.leftCols(a) * gamma.cast<float>();
        }
      }
    }
  });
  return codes;
}

MatrixF decode(const MatrixF& D, const SparseCodes& codes) {
  const size_t n = codes.count();
  MatrixF X = MatrixF::Zero(D.rows(), Eigen::Index(n));
  for (size_t i = 0; i < n; ++i)
    for (int j = 0; j < codes.sparsity; ++j) {
      const int a = codes.index[i * codes.sparsity + j];
      if (a >= 0) X.col(i) += codes.coef[i * codes.sparsity + j] * D.col(a);
    }
  return X;
}

}  // namespace terracl
