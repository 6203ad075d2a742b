// SPDX-License-Identifier: Apache-2.0
// Single-atom search (s = 1). For unit-norm zero-mean atoms, max |<q, d>| over d is the nearest
// neighbour of q/|q| among {+d, -d}: |q^ - d|^2 = 2 - 2 <q^, d>. A FLANN randomized kd-tree forest
// answers that approximately, far faster than the exact scan for large (complete) dictionaries.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

// Every standard header FLANN uses is included before the shim below, so the macros only reach
// FLANN's own code.
#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>

namespace terracl::flann_seed {
// Reproducibility shim. Debian's FLANN 1.9.2 randomises its kd-trees from two sources that no API
// seeds: KDTreeIndex::buildIndexImpl shuffles the points of every tree with
// std::mt19937(std::random_device{}()), and selectDivision picks the split dimension with
// std::rand() (flann::seed_random is srand, process-global and shared with any other rand() user).
// So the approximate search, and the amplified output, changed from run to run. While FLANN's
// headers are read, `std::random_device` and `std::rand()` are redirected to a per-thread SplitMix64
// stream that AtomIndex seeds right before each build (FLANN builds kd-trees in the calling
// thread): the forest is still FLANN's own, but a given seed gives the same trees everywhere.
// The macros expand to standard names (std::enable_if_t, std::ref), so nothing is added to std.
inline thread_local uint64_t state = 0x9e3779b97f4a7c15ull;
inline uint64_t next() {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
inline int next_rand() { return int(next() % (uint64_t(RAND_MAX) + 1)); }
struct SeededDevice {
  using result_type = unsigned int;
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }
  result_type operator()() { return result_type(next() >> 32); }
  double entropy() const noexcept { return 0; }
};
}  // namespace terracl::flann_seed

#define random_device enable_if_t<true, ::terracl::flann_seed::SeededDevice>
#define rand() ref(::terracl::flann_seed::next_rand)()
#include <flann/flann.hpp>
#undef rand
#undef random_device

#include "amplify/simd_clones.hpp"

namespace terracl {

float magnitude_feature(float norm) { return std::log(norm + 0.1f); }

namespace {
// In index order, not vectorised: Eigen's reductions peel by the column's address, which for a
// query depends on its place in the batch; these give a query the same value in every batch.
float column_norm(const MatrixF& m, size_t c) {
  const float* x = m.data() + c * size_t(m.rows());
  float s = 0;
  for (Eigen::Index i = 0; i < m.rows(); ++i) s += x[i] * x[i];
  return std::sqrt(s);
}
float column_dot(const MatrixF& a, size_t ca, const MatrixF& b, size_t cb) {
  const float* x = a.data() + ca * size_t(a.rows());
  const float* y = b.data() + cb * size_t(b.rows());
  float s = 0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) s += x[i] * y[i];
  return s;
}

// score[j] = 2 |a_j| / |q| - w^2 (feature(q) - feature(d_j))^2 (no magnitude term without `feat`).
TERRACL_SIMD_CLONES void score_atoms(const float* a, const float* feat, size_t N, float nrm, float fq, float w2,
                                     float* score) {
  if (feat)
    for (size_t j = 0; j < N; ++j) score[j] = 2 * std::fabs(a[j]) / nrm - w2 * (fq - feat[j]) * (fq - feat[j]);
  else
    for (size_t j = 0; j < N; ++j) score[j] = 2 * std::fabs(a[j]) / nrm;
}

bool magnitude_active(const std::vector<float>* atom_norm, float weight, size_t atoms) {
  if (!(weight > 0) || !atom_norm || atom_norm->empty()) return false;
  if (atom_norm->size() != atoms) fail("amplify", "{} atom norms for {} atoms", atom_norm->size(), atoms);
  return true;
}
}  // namespace

AtomMatch exact_atom_search(const MatrixF& D, const MatrixF& Q, int threads, int k, const std::vector<float>* atom_norm,
                            float weight, float query_scale) {
  if (D.rows() != Q.rows()) fail("amplify", "query length {} differs from atom length {}", Q.rows(), D.rows());
  if (k < 1) fail("amplify", "neighbours must be >= 1 (got {})", k);
  const size_t n = size_t(Q.cols()), N = size_t(D.cols()), kk = std::min(size_t(k), N);
  const bool mag = magnitude_active(atom_norm, weight, N);
  std::vector<float> feat;
  if (mag)
    for (float v : *atom_norm) feat.push_back(magnitude_feature(v));
  const float w2 = weight * weight;
  AtomMatch m;
  m.index.assign(n * size_t(k), -1);
  m.coef.assign(n * size_t(k), 0.f);
  constexpr size_t kBlock = 256;
  const size_t blocks = (n + kBlock - 1) / kBlock;
  parallel_for(blocks, threads, [&](size_t b0, size_t b1) {
    std::vector<std::pair<float, int32_t>> best;  // (score, atom), the kk highest, best first
    std::vector<float> score(N);
    MatrixF qb(Q.rows(), Eigen::Index(kBlock));
    for (size_t b = b0; b < b1; ++b) {
      const size_t c0 = b * kBlock, cn = std::min(kBlock, n - c0);
      // Always a full block (zero-padded): every query's scores then come from the same product
      // shape, so a query scores the same whatever batch it is in (tiled amplify is exact).
      qb.setZero();
      qb.leftCols(Eigen::Index(cn)) = Q.middleCols(Eigen::Index(c0), Eigen::Index(cn));
      const MatrixF A = D.transpose() * qb;
      for (size_t c = 0; c < cn; ++c) {
        const float nrm = column_norm(Q, c0 + c);
        if (!(nrm > 0)) continue;
        // The FLANN criterion (search below): minimise |q/|q| -+ d|^2 + w^2 (feature(q) - feature(d))^2.
        // Scores first, in one vectorised pass; then the selection.
        const float fq = mag ? magnitude_feature(nrm * query_scale) : 0.f;
        const float* a = A.data() + c * size_t(A.rows());
        score_atoms(a, mag ? feat.data() : nullptr, N, nrm, fq, w2, score.data());
        best.clear();
        float kth = 0;  // the kk-th best score, once there are kk
        auto consider = [&](size_t j) {
          const float sj = score[j];
          if (best.size() == kk && !(sj > kth)) return;
          if (best.size() == kk) best.pop_back();
          auto it = std::upper_bound(best.begin(), best.end(), sj,
                                     [](float s, const std::pair<float, int32_t>& e) { return s > e.first; });
          best.insert(it, {sj, int32_t(j)});
          kth = best.back().first;
        };
        size_t j = 0;
        for (; j < N && best.size() < kk; ++j) consider(j);
        // Once there are kk, most runs of scores hold none above the kk-th: test a run at once.
        constexpr size_t kRun = 16;
        for (; j + kRun <= N; j += kRun) {
          const float* sr = score.data() + j;
          int above = 0;
          for (size_t i = 0; i < kRun; ++i) above += sr[i] > kth ? 1 : 0;
          if (above)
            for (size_t i = j; i < j + kRun; ++i) consider(i);
        }
        for (; j < N; ++j) consider(j);
        for (size_t t = 0; t < best.size(); ++t) {
          m.index[(c0 + c) * size_t(k) + t] = best[t].second;
          m.coef[(c0 + c) * size_t(k) + t] = A(best[t].second, Eigen::Index(c));
        }
      }
    }
  });
  return m;
}

struct AtomIndex::Impl {
  std::vector<float> points;  // 2N x K row-major: +d then -d (and the magnitude feature when used)
  std::unique_ptr<flann::Index<flann::L2<float>>> index;
};

AtomIndex::AtomIndex(const MatrixF& D, int trees, int checks, unsigned seed, const std::vector<float>* atom_norm,
                     float weight)
    : m_impl(new Impl), m_atoms(D), m_trees(trees), m_checks(checks) {
  if (trees < 1) fail("amplify", "FLANN trees must be >= 1 (got {})", trees);
  if (checks == 0) fail("amplify", "FLANN checks must be > 0, or negative for unlimited");
  const size_t N = size_t(D.cols()), K0 = size_t(D.rows());
  if (N == 0) fail("amplify", "empty dictionary");
  if (magnitude_active(atom_norm, weight, N)) m_weight = weight;
  const size_t K = K0 + (m_weight > 0 ? 1 : 0);
  m_impl->points.resize(2 * N * K);
  for (size_t j = 0; j < N; ++j) {
    for (size_t k = 0; k < K0; ++k) {
      m_impl->points[j * K + k] = D(Eigen::Index(k), Eigen::Index(j));
      m_impl->points[(N + j) * K + k] = -D(Eigen::Index(k), Eigen::Index(j));
    }
    // Both signs of an atom come from one exemplar patch, of one magnitude.
    if (m_weight > 0) m_impl->points[j * K + K0] = m_impl->points[(N + j) * K + K0] = m_weight * magnitude_feature((*atom_norm)[j]);
  }
  // Unlimited checks visit every leaf: one tree is then exact and FLANN warns about more.
  if (checks < 0) m_trees = 1;
  flann::Matrix<float> data(m_impl->points.data(), 2 * N, K);
  m_impl->index = std::make_unique<flann::Index<flann::L2<float>>>(data, flann::KDTreeIndexParams(m_trees));
  flann_seed::state = 0x243f6a8885a308d3ull ^ (uint64_t(seed) * 0x9e3779b97f4a7c15ull);  // see the shim above
  m_impl->index->buildIndex();
}

AtomIndex::~AtomIndex() { delete m_impl; }

AtomMatch AtomIndex::search(const MatrixF& Q, int threads, int k, float query_scale) const {
  const size_t n = size_t(Q.cols()), K0 = size_t(Q.rows()), N = size_t(m_atoms.cols());
  const size_t K = K0 + (m_weight > 0 ? 1 : 0);
  if (K0 != size_t(m_atoms.rows())) fail("amplify", "query length {} differs from atom length {}", K0, m_atoms.rows());
  if (k < 1) fail("amplify", "neighbours must be >= 1 (got {})", k);
  const size_t kk = size_t(k);
  AtomMatch m;
  m.index.assign(n * kk, -1);
  m.coef.assign(n * kk, 0.f);
  flann::SearchParams params(m_checks < 0 ? flann::FLANN_CHECKS_UNLIMITED : m_checks);
  params.cores = 1;  // parallelism is ours (one FLANN call per thread chunk)
  constexpr size_t kBlock = 512;
  const size_t blocks = (n + kBlock - 1) / kBlock;
  parallel_for(blocks, threads, [&](size_t b0, size_t b1) {
    std::vector<float> q(kBlock * K);
    std::vector<size_t> idx(kBlock * kk);
    std::vector<float> dist(kBlock * kk);
    std::vector<size_t> live;
    for (size_t b = b0; b < b1; ++b) {
      const size_t c0 = b * kBlock, cn = std::min(kBlock, n - c0);
      live.clear();
      for (size_t c = 0; c < cn; ++c) {
        const auto col = Q.col(Eigen::Index(c0 + c));
        const float nrm = column_norm(Q, c0 + c);
        if (!(nrm > 0)) continue;
        for (size_t k2 = 0; k2 < K0; ++k2) q[live.size() * K + k2] = col[Eigen::Index(k2)] / nrm;
        if (m_weight > 0) q[live.size() * K + K0] = m_weight * magnitude_feature(nrm * query_scale);
        live.push_back(c);
      }
      if (live.empty()) continue;
      flann::Matrix<float> qm(q.data(), live.size(), K);
      flann::Matrix<size_t> im(idx.data(), live.size(), kk);
      flann::Matrix<float> dm(dist.data(), live.size(), kk);
      std::fill(idx.begin(), idx.end(), size_t(-1));
      m_impl->index->knnSearch(qm, im, dm, kk, params);
      for (size_t i = 0; i < live.size(); ++i) {
        const size_t c = live[i];
        for (size_t t = 0; t < kk; ++t) {
          if (idx[i * kk + t] >= 2 * N) continue;  // fewer than k neighbours found
          const size_t a = idx[i * kk + t] % N;
          m.index[(c0 + c) * kk + t] = int32_t(a);
          m.coef[(c0 + c) * kk + t] = column_dot(m_atoms, a, Q, c0 + c);
        }
      }
    }
  });
  return m;
}

RecallReport measure_recall(const MatrixF& D, const MatrixF& Q, int trees, int checks, int samples, unsigned seed,
                            const std::vector<float>* atom_norm, float weight) {
  RecallReport r;
  const Eigen::Index n = Q.cols();
  const int m = int(std::min<Eigen::Index>(samples, n));
  if (m == 0) return r;
  MatrixF S(Q.rows(), m);
  for (int i = 0; i < m; ++i) S.col(i) = Q.col(Eigen::Index(double(i) * n / m));
  AtomIndex index(D, trees, checks, seed, atom_norm, weight);
  using clock = std::chrono::steady_clock;
  auto t0 = clock::now();
  const AtomMatch a = index.search(S, 1);
  auto t1 = clock::now();
  const AtomMatch e = exact_atom_search(D, S, 1, 1, atom_norm, weight);
  auto t2 = clock::now();
  int same = 0, live = 0;
  for (int i = 0; i < m; ++i) {
    if (e.index[i] < 0) continue;
    ++live;
    // Ties (duplicate atoms) count as agreement when the correlations are equal.
    if (a.index[i] == e.index[i] || std::fabs(std::fabs(a.coef[i]) - std::fabs(e.coef[i])) <= 1e-6f * std::fabs(e.coef[i]))
      ++same;
  }
  r.samples = live;
  r.recall = live ? double(same) / live : 1.0;
  r.ms_per_query_flann = std::chrono::duration<double, std::milli>(t1 - t0).count() / m;
  r.ms_per_query_exact = std::chrono::duration<double, std::milli>(t2 - t1).count() / m;
  return r;
}

}  // namespace terracl
