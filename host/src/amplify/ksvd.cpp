// SPDX-License-Identifier: Apache-2.0
// K-SVD dictionary learning (Aharon, Elad, Bruckstein 2006) and the constrained variant of the sparse
// terrain paper (problem 2), whose atoms must be training signals so that a multi-resolution
// dictionary made from them holds real terrain.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace terracl {

namespace {

// Rank-1 fit of E (K x m) started from d: alternating least squares, each half-step lowers
// |E - d x^T| (monotone), and a few steps from the previous atom reach the leading singular pair.
void rank1_update(const MatrixF& E, VectorF& d, VectorF& x, int steps = 3) {
  for (int it = 0; it < steps; ++it) {
    x.noalias() = E.transpose() * d;
    VectorF nd = E * x;
    const float nn = nd.norm();
    if (!(nn > 0)) break;
    d = nd / nn;
  }
  x.noalias() = E.transpose() * d;
}

}  // namespace

KsvdResult learn_ksvd(const MatrixF& F, const KsvdOptions& o, const Progress& progress) {
  const int K = int(F.rows());
  const int n = int(F.cols());
  if (n == 0 || K == 0) fail("ksvd", "no training signals");
  if (o.atoms < 1 || o.sparsity < 1 || o.iterations < 0)
    fail("ksvd", "atoms and sparsity must be >= 1, iterations >= 0 (got {}, {}, {})", o.atoms, o.sparsity, o.iterations);
  std::mt19937 rng(o.seed);

  VectorF norms(n);
  for (int i = 0; i < n; ++i) norms[i] = F.col(i).norm();
  std::vector<int> usable;
  for (int i = 0; i < n; ++i)
    if (norms[i] > 0) usable.push_back(i);
  if (usable.empty()) fail("ksvd", "every training signal is zero (flat exemplar?)");
  const int N = std::min<int>(o.atoms, int(usable.size()));
  std::shuffle(usable.begin(), usable.end(), rng);

  KsvdResult r;
  r.D.resize(K, N);
  r.source.assign(N, -1);
  for (int j = 0; j < N; ++j) {
    r.D.col(j) = F.col(usable[j]) / norms[usable[j]];
    r.source[j] = usable[j];
  }
  if (!o.constrained) std::fill(r.source.begin(), r.source.end(), -1);

  const int s = o.sparsity;
  for (int it = 0; it < o.iterations; ++it) {
    report_progress(progress, "ksvd", double(it) / std::max(1, o.iterations),
                    fmt::format("iteration {}/{}", it + 1, o.iterations));
    SparseCodes codes = batch_omp(r.D, F, s, o.threads);
    MatrixF R = F - decode(r.D, codes);
    // Signals using each atom (slot positions in codes).
    std::vector<std::vector<size_t>> users(N);
    for (size_t k = 0; k < codes.index.size(); ++k)
      if (codes.index[k] >= 0) users[codes.index[k]].push_back(k);

    for (int j = 0; j < N; ++j) {
      const auto& u = users[j];
      VectorF d = r.D.col(j);
      if (u.empty()) {
        // Unused atom: replace it by the worst represented signal (standard K-SVD practice).
        int worst = 0;
        float we = -1;
        for (int i = 0; i < n; ++i) {
          const float e = R.col(i).squaredNorm();
          if (e > we) we = e, worst = i;
        }
        if (we > 0 && norms[worst] > 0) {
          r.D.col(j) = F.col(worst) / norms[worst];
          if (o.constrained) r.source[j] = worst;
        }
        continue;
      }
      const int m = int(u.size());
      MatrixF E(K, m);
      for (int c = 0; c < m; ++c) {
        const size_t sig = u[c] / s;
        E.col(c) = R.col(sig) + codes.coef[u[c]] * d;
      }
      VectorF x;
      if (!o.constrained) {
        rank1_update(E, d, x);
      } else {
        // Exhaustive search over all n signals is O(n K m) per atom; shortlist by the leading
        // singular vector, then score the shortlist (plus the current atom) exactly.
        VectorF lead = d;
        rank1_update(E, lead, x, 2);
        std::vector<int> cand;
        for (int c = 0; c < m; ++c) cand.push_back(int(u[c] / s));
        std::uniform_int_distribution<int> pick(0, n - 1);
        for (int c = 0; c < 512; ++c) cand.push_back(pick(rng));
        std::vector<std::pair<float, int>> scored;
        for (int c : cand)
          if (norms[c] > 0) scored.push_back({-std::fabs(lead.dot(F.col(c))) / norms[c], c});
        const size_t keep = std::min<size_t>(8, scored.size());
        std::partial_sort(scored.begin(), scored.begin() + keep, scored.end());
        double best = (E.transpose() * d).squaredNorm();
        int best_src = r.source[j];
        for (size_t c = 0; c < keep; ++c) {
          const int src = scored[c].second;
          const VectorF f = F.col(src) / norms[src];
          const double sc = (E.transpose() * f).squaredNorm();
          if (sc > best) best = sc, best_src = src, d = f;
        }
        r.source[j] = best_src;
        x.noalias() = E.transpose() * d;
      }
      r.D.col(j) = d;
      for (int c = 0; c < m; ++c) {
        const size_t sig = u[c] / s;
        codes.coef[u[c]] = x[c];
        R.col(sig) = E.col(c) - x[c] * d;
      }
    }
    r.rmse.push_back(std::sqrt(double(R.squaredNorm()) / (double(K) * n)));
  }
  report_progress(progress, "ksvd", 1.0, "done");
  return r;
}

}  // namespace terracl
