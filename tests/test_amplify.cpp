// SPDX-License-Identifier: Apache-2.0
// Numerics of the sparse-dictionary amplification: OMP, K-SVD, complete dictionaries, FLANN search,
// block-mean correction, dictionary files.
#include "test_helpers.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cstring>
#include <fstream>
#include <random>

using namespace terracl;

namespace {

MatrixF random_dictionary(int K, int N, unsigned seed, bool zero_mean = false) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  MatrixF D(K, N);
  for (int j = 0; j < N; ++j) {
    for (int k = 0; k < K; ++k) D(k, j) = g(rng);
    if (zero_mean) D.col(j).array() -= D.col(j).mean();
    D.col(j).normalize();
  }
  return D;
}

// Textbook OMP: correlation with the residual picks the atom, a fresh QR least-squares solve on the
// active set gives the coefficients (no Gram matrix, no Cholesky updates).
std::pair<std::vector<int>, VectorF> reference_omp(const MatrixF& D, const VectorF& x, int s) {
  std::vector<int> I;
  VectorF r = x, c;
  for (int k = 0; k < s; ++k) {
    Eigen::Index best;
    (D.transpose() * r).cwiseAbs().maxCoeff(&best);
    I.push_back(int(best));
    MatrixF A(D.rows(), Eigen::Index(I.size()));
    for (size_t i = 0; i < I.size(); ++i) A.col(Eigen::Index(i)) = D.col(I[i]);
    c = A.colPivHouseholderQr().solve(x);
    r = x - A * c;
  }
  return {I, c};
}

Heightfield crop_of(const Heightfield& h, int x0, int y0, int w, int ht) {
  Heightfield c(w, ht);
  c.georef = h.georef;
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  return c;
}

Heightfield rough_terrain(int w, int h, double cell, unsigned seed, float noise = 6.f) {
  Heightfield t = test::smooth_terrain(w, h, cell, 40.0, seed);
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.f, noise);
  for (auto& v : t.z) v += g(rng);
  return t;
}

LearnOptions small_learn(const std::string& method = "complete") {
  LearnOptions l;
  l.method = method;
  l.atoms = 64;
  l.iterations = 2;
  l.max_patches = 3000;
  l.calibrate = false;
  return l;
}

}  // namespace

TEST(AmplifyOmp, MatchesReferenceLeastSquares) {
  const MatrixF D = random_dictionary(24, 60, 3);
  std::mt19937 rng(5);
  std::normal_distribution<float> g;
  MatrixF X(24, 40);
  for (int i = 0; i < 40; ++i) X.col(i) = VectorF::NullaryExpr(24, [&] { return g(rng); });
  for (int s : {1, 2, 4}) {
    const SparseCodes c = batch_omp(D, X, s, 2);
    for (int i = 0; i < 40; ++i) {
      const auto [I, coef] = reference_omp(D, X.col(i), s);
      for (int j = 0; j < s; ++j) {
        EXPECT_EQ(c.index[size_t(i) * s + j], I[j]) << "signal " << i << " s=" << s;
        EXPECT_NEAR(c.coef[size_t(i) * s + j], coef[j], 1e-4f * (1 + std::fabs(coef[j])));
      }
    }
  }
}

TEST(AmplifyOmp, RecoversExactlySparseSignals) {
  const MatrixF D = random_dictionary(64, 128, 7);
  SparseCodes truth;
  MatrixF X = MatrixF::Zero(64, 20);
  std::mt19937 rng(9);
  for (int i = 0; i < 20; ++i) {
    const int a = int(rng() % 128), b = (a + 1 + int(rng() % 127)) % 128;
    X.col(i) = 2.0f * D.col(a) - 1.5f * D.col(b);
  }
  const SparseCodes c = batch_omp(D, X, 2);
  EXPECT_LT((decode(D, c) - X).norm(), 1e-4f * X.norm());
  // A larger sparsity stops early once the residual vanishes.
  const SparseCodes c4 = batch_omp(D, X, 4);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(c4.index[size_t(i) * 4 + 2], -1);
}

TEST(AmplifyKsvd, ErrorDecreasesEveryIteration) {
  const MatrixF G = random_dictionary(16, 24, 11);
  std::mt19937 rng(13);
  std::normal_distribution<float> g;
  MatrixF F(16, 600);
  for (int i = 0; i < 600; ++i)
    F.col(i) = g(rng) * G.col(int(rng() % 24)) + g(rng) * G.col(int(rng() % 24)) + 0.01f * VectorF::NullaryExpr(16, [&] { return g(rng); });
  for (bool constrained : {false, true}) {
    KsvdOptions o;
    o.atoms = 24;
    o.sparsity = 2;
    o.iterations = 8;
    o.constrained = constrained;
    const KsvdResult r = learn_ksvd(F, o);
    ASSERT_EQ(r.rmse.size(), 8u);
    for (size_t i = 1; i < r.rmse.size(); ++i) EXPECT_LE(r.rmse[i], r.rmse[i - 1] * 1.01) << "iteration " << i;
    EXPECT_LT(r.rmse.back(), r.rmse.front() * (constrained ? 0.95 : 0.5));
    for (int j = 0; j < r.D.cols(); ++j) EXPECT_NEAR(r.D.col(j).norm(), 1.0f, 1e-4f);
  }
}

TEST(AmplifyKsvd, ConstrainedAtomsAreTrainingPatches) {
  const Heightfield h = test::smooth_terrain(64, 64, 10.0, 200.0, 3);
  const MatrixF F = extract_patches(h, 8, 2);
  KsvdOptions o;
  o.atoms = 32;
  o.sparsity = 2;
  o.iterations = 3;
  o.constrained = true;
  const KsvdResult r = learn_ksvd(F, o);
  ASSERT_EQ(r.D.cols(), 32);
  for (int j = 0; j < 32; ++j) {
    ASSERT_GE(r.source[j], 0);
    const VectorF f = F.col(r.source[j]) / F.col(r.source[j]).norm();
    EXPECT_LT((r.D.col(j) - f).norm(), 1e-5f) << "atom " << j;
  }
}

TEST(AmplifyPatches, CompleteDictionaryIsExactAtSparsityOne) {
  const Heightfield h = read_heightfield(test::data_path("crops/frontrange_64.asc"));
  std::vector<float> means;
  std::vector<std::pair<int, int>> pos;
  const MatrixF F = extract_patches(h, 8, 4, &means, &pos);
  MatrixF D = F;
  for (int j = 0; j < D.cols(); ++j) D.col(j).normalize();
  const SparseCodes c = batch_omp(D, F, 1);
  const Heightfield rec = blend_patches(h.width, h.height, 8, decode(D, c), means, pos);
  size_t covered = 0;
  double err = 0;
  for (size_t i = 0; i < h.size(); ++i)
    if (std::isfinite(rec.z[i])) ++covered, err = std::max(err, double(std::fabs(rec.z[i] - h.z[i])));
  EXPECT_GT(covered, h.size() * 95 / 100);  // only the outer corners lie outside every disc
  EXPECT_LT(err, 1e-3);
}

TEST(AmplifyPatches, WeightIsC1AndVanishesAtTheRim) {
  EXPECT_DOUBLE_EQ(disc_weight(0), 1.0);
  EXPECT_DOUBLE_EQ(disc_weight(1.0), 0.0);
  EXPECT_NEAR((disc_weight(1.0) - disc_weight(1.0 - 1e-4)) / 1e-4, 0.0, 1e-6);  // zero slope at r = 1
  EXPECT_NEAR(disc_weight(0.5), 0.421875, 1e-12);
}

TEST(AmplifyFlann, EqualsExactSearchWithUnlimitedChecks) {
  const MatrixF D = random_dictionary(16, 700, 21, true);
  const MatrixF Q = random_dictionary(16, 400, 22, true) * 3.0f;
  const AtomMatch e = exact_atom_search(D, Q);
  AtomIndex idx(D, 4, -1);
  const AtomMatch a = idx.search(Q, 2);
  for (int i = 0; i < 400; ++i) {
    EXPECT_EQ(a.index[i], e.index[i]);
    EXPECT_NEAR(a.coef[i], e.coef[i], 1e-4f);
  }
  const RecallReport r = measure_recall(D, Q, 4, -1, 200);
  EXPECT_EQ(r.recall, 1.0);
  const RecallReport few = measure_recall(D, Q, 1, 1, 200);
  EXPECT_LT(few.recall, 1.0);  // one leaf check really is approximate
}

TEST(AmplifyFlann, SameSeedGivesIdenticalForests) {
  // FLANN randomises each kd-tree; AtomIndex seeds that randomness (flann_search.cpp), so two builds
  // with one seed give the same approximate answers and another seed gives other trees.
  const MatrixF D = random_dictionary(16, 3000, 31, true);
  const MatrixF Q = random_dictionary(16, 1000, 32, true);
  auto run = [&](unsigned seed) { return AtomIndex(D, 4, 8, seed).search(Q, 2); };
  const AtomMatch a = run(7), b = run(7), c = run(8);
  const AtomMatch e = exact_atom_search(D, Q);
  EXPECT_EQ(a.index, b.index);
  EXPECT_EQ(a.coef, b.coef);
  EXPECT_NE(a.index, e.index);  // checks 8 really is approximate here, so the trees matter
  EXPECT_NE(a.index, c.index);  // and the seed reaches FLANN
  EXPECT_EQ(measure_recall(D, Q, 4, 8, 500, 3).recall, measure_recall(D, Q, 4, 8, 500, 3).recall);
}

TEST(AmplifyFlann, KNearestWithMagnitudeTermMatchBruteForce) {
  const MatrixF D = random_dictionary(16, 500, 41, true);
  const MatrixF Q = random_dictionary(16, 200, 42, true) * 20.0f;
  std::mt19937 rng(43);
  std::uniform_real_distribution<float> u(0.5f, 200.f);
  std::vector<float> norms(500);
  for (auto& v : norms) v = u(rng);
  const float w = 0.5f, scale = 0.7f;
  const int k = 3;
  const AtomMatch e = exact_atom_search(D, Q, 2, k, &norms, w, scale);
  const AtomMatch a = AtomIndex(D, 2, -1, 1, &norms, w).search(Q, 2, k, scale);
  for (int i = 0; i < 200; ++i) {
    // Independent reference: squared distance of the augmented vectors, both signs, sorted.
    const VectorF q = Q.col(i) / Q.col(i).norm();
    const float fq = std::log(Q.col(i).norm() * scale + 0.1f);
    std::vector<std::pair<double, int>> dist;
    for (int j = 0; j < 500; ++j) {
      const double m = w * (fq - std::log(norms[j] + 0.1f));
      dist.push_back({std::min((q - D.col(j)).squaredNorm(), (q + D.col(j)).squaredNorm()) + m * m, j});
    }
    std::sort(dist.begin(), dist.end());
    for (int t = 0; t < k; ++t) {
      EXPECT_EQ(e.index[i * k + t], dist[t].second);
      EXPECT_EQ(a.index[i * k + t], dist[t].second);
      EXPECT_NEAR(e.coef[i * k + t], D.col(dist[t].second).dot(Q.col(i)), 1e-3f);
    }
  }
}

TEST(AmplifyFlann, MagnitudeTermPrefersAtomsOfTheQuerysRelief) {
  // Two atoms of nearly one shape, cut from gentle (1 m) and rugged (80 m) patches.
  MatrixF D = random_dictionary(16, 2, 44, true);
  D.col(1) = (D.col(0) + 0.05f * D.col(1)).normalized();
  const std::vector<float> norms{1.f, 80.f};
  MatrixF Q(16, 2);
  Q.col(0) = 80.f * D.col(0);  // exactly atom 0's shape, but rugged
  Q.col(1) = 1.f * D.col(0);
  EXPECT_EQ(exact_atom_search(D, Q, 1).index[0], 0);  // shape only
  const AtomMatch m = exact_atom_search(D, Q, 1, 1, &norms, 0.4f);
  EXPECT_EQ(m.index[0], 1);
  EXPECT_EQ(m.index[1], 0);
  EXPECT_EQ(AtomIndex(D, 1, -1, 1, &norms, 0.4f).search(Q, 1).index, m.index);
}

TEST(AmplifyAmplify, FlannOutputIsBitIdenticalAcrossRuns) {
  const Dictionary d = learn_dictionary({rough_terrain(96, 96, 5.0, 11)}, small_learn());
  const Heightfield low = block_mean(rough_terrain(96, 96, 5.0, 12, 3.f), 4);
  AmplifyOptions o;
  o.search = "flann";
  o.checks = 2;
  o.seed = 5;
  const Heightfield a = amplify(low, d, o), b = amplify(low, d, o);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.z.data(), b.z.data(), a.size() * sizeof(float)));
  o.search = "exact";
  const Heightfield e = amplify(low, d, o);
  EXPECT_NE(0, std::memcmp(a.z.data(), e.z.data(), a.size() * sizeof(float)));  // the approximation shows
}

TEST(AmplifyCorrection, BlockMeansMatchInput) {
  Heightfield high = rough_terrain(96, 64, 10.0, 4);
  Heightfield low = block_mean(test::smooth_terrain(96, 64, 10.0, 300.0, 9), 4);
  correct_block_means(high, low, 4);
  const Heightfield m = block_mean(high, 4);
  for (size_t i = 0; i < m.size(); ++i) EXPECT_NEAR(m.z[i], low.z[i], 1e-3f);
}

TEST(AmplifyCorrection, BicubicReproducesLinearRamps) {
  Heightfield low(12, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 12; ++x) low.at(x, y) = 3.0f * x - 2.0f * y;
  const Heightfield up = bicubic_upsample(low, 4);
  // Away from the clamped border, cell-centre alignment gives z = 3 (X + 0.5)/4 - 3/2 ... exactly.
  for (int Y = 8; Y < 32; ++Y)
    for (int X = 8; X < 40; ++X) EXPECT_NEAR(up.at(X, Y), 3.0 * ((X + 0.5) / 4 - 0.5) - 2.0 * ((Y + 0.5) / 4 - 0.5), 1e-4);
}

TEST(AmplifyDictionary, SaveLoadRoundTrip) {
  test::TempDir tmp;
  const Dictionary d = learn_dictionary({rough_terrain(64, 64, 5.0, 2)}, small_learn("ksvd"));
  save_dictionary(d, tmp.path("d.tdic"));
  const Dictionary e = load_dictionary(tmp.path("d.tdic"));
  EXPECT_EQ(e.patch, d.patch);
  EXPECT_EQ(e.factor, d.factor);
  EXPECT_EQ(e.sparsity, d.sparsity);
  EXPECT_EQ(e.constrained, d.constrained);
  EXPECT_EQ(e.cell_x, d.cell_x);
  EXPECT_EQ(e.detail_gain, d.detail_gain);
  EXPECT_EQ(e.description, d.description);
  EXPECT_EQ(e.neighbours, 3);
  EXPECT_EQ(e.magnitude_weight, 0.4f);
  EXPECT_TRUE(e.high == d.high);
  EXPECT_TRUE(e.low == d.low);
  EXPECT_TRUE(e.low_norm.empty());  // K-SVD atoms have no source patch
  // L is the normalised block mean of H.
  for (int j = 0; j < d.atoms(); ++j) EXPECT_NEAR(d.low.col(j).norm(), 1.0f, 1e-4f);
  // Complete and constrained atoms keep the norm of the low-resolution patch they were cut from.
  for (const char* method : {"complete", "constrained"}) {
    const Dictionary c = learn_dictionary({rough_terrain(64, 64, 5.0, 2)}, small_learn(method));
    ASSERT_EQ(c.low_norm.size(), size_t(c.atoms())) << method;
    save_dictionary(c, tmp.path("c.tdic"));
    EXPECT_EQ(load_dictionary(tmp.path("c.tdic")).low_norm, c.low_norm) << method;
  }
  // Complete: H times the norm is an exemplar window (up to its mean), found by brute force.
  const Heightfield ex = rough_terrain(64, 64, 5.0, 2);
  const Dictionary c = learn_dictionary({ex}, small_learn("complete"));
  for (int j = 0; j < c.atoms(); j += 97) {
    const VectorF h = c.high.col(j) * c.low_norm[j];
    double best = 1e30;
    for (int y = 0; y + 16 <= 64; y += 2)
      for (int x = 0; x + 16 <= 64; x += 2) {
        VectorF diff(256);
        for (int v = 0; v < 16; ++v)
          for (int u = 0; u < 16; ++u) diff[v * 16 + u] = ex.at(x + u, y + v) - h[v * 16 + u];
        best = std::min(best, double((diff.array() - diff.mean()).abs().maxCoeff()));
      }
    EXPECT_LT(best, 1e-2) << "atom " << j;
  }
}

TEST(AmplifyDictionary, VersionOneFilesStillLoad) {
  // A version 1 file is version 2 without the search settings (bytes 48-55) and the norms (flag
  // bit 1 clear), with version = 1.
  test::TempDir tmp;
  Dictionary d = learn_dictionary({rough_terrain(48, 48, 5.0, 2)}, small_learn());
  d.low_norm.clear();
  save_dictionary(d, tmp.path("d.tdic"));
  std::string bytes;
  {
    std::ifstream f(tmp.path("d.tdic"), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  ASSERT_EQ(bytes[4], 5);
  ASSERT_FALSE(d.has_regression());  // 12 x 12 input cells: too few 7 x 7 neighbourhoods
  ASSERT_LT(d.spectral_scale, 0);    // too small to calibrate: no calibration block (flag bit 5)
  bytes[4] = 1;
  bytes.erase(48, 8);
  uint64_t h = 1469598103934665603ull;  // FNV-1a 64 of everything before the hash
  for (size_t i = 0; i + 8 < bytes.size(); ++i) h = (h ^ (unsigned char)bytes[i]) * 1099511628211ull;
  for (int i = 0; i < 8; ++i) bytes[bytes.size() - 8 + i] = char((h >> (8 * i)) & 0xff);
  std::ofstream(tmp.path("v1.tdic"), std::ios::binary) << bytes;
  const Dictionary e = load_dictionary(tmp.path("v1.tdic"));
  EXPECT_TRUE(e.high == d.high);
  EXPECT_TRUE(e.low_norm.empty());
  EXPECT_EQ(e.neighbours, 1);  // its gain was calibrated for the nearest atom alone
  EXPECT_EQ(e.magnitude_weight, 0.f);
  EXPECT_FALSE(e.anisotropy);  // and for one detail correlation rho
  bytes[4] = 6;
  std::ofstream(tmp.path("v6.tdic"), std::ios::binary) << bytes;
  EXPECT_THROW(load_dictionary(tmp.path("v6.tdic")), Error);
}

namespace {
std::string file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}
// Rewrites the trailing FNV-1a 64 hash after an edit.
void rehash(std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i + 8 < bytes.size(); ++i) h = (h ^ (unsigned char)bytes[i]) * 1099511628211ull;
  for (int i = 0; i < 8; ++i) bytes[bytes.size() - 8 + i] = char((h >> (8 * i)) & 0xff);
}
}  // namespace

TEST(AmplifyDictionary, FaithfulRegressionRoundTripsBitForBit) {
  test::TempDir tmp;
  const Heightfield ex = rough_terrain(96, 96, 5.0, 3);
  const Dictionary d = learn_dictionary({ex}, small_learn());
  ASSERT_TRUE(d.has_regression());
  EXPECT_EQ(d.regression.radius, 3);
  EXPECT_EQ(d.regression.samples, 18 * 18);  // 24 x 24 input cells, 7 x 7 neighbourhoods inside
  // The stored regression is the one learn_block_regression gives on the same exemplar.
  const BlockRegression g = learn_block_regression({ex}, 4, 3);
  ASSERT_EQ(g.weights.size(), d.regression.weights.size());
  EXPECT_TRUE(g.weights[0] == d.regression.weights[0]);
  save_dictionary(d, tmp.path("d.tdic"));
  const Dictionary e = load_dictionary(tmp.path("d.tdic"));
  ASSERT_TRUE(e.has_regression());
  EXPECT_EQ(e.regression.radius, d.regression.radius);
  EXPECT_EQ(e.regression.classes, d.regression.classes);
  EXPECT_EQ(e.regression.samples, d.regression.samples);
  EXPECT_EQ(e.regression.factor, 4);
  EXPECT_EQ(e.base, "bandlimited");
  for (size_t c = 0; c < d.regression.weights.size(); ++c) {
    const MatrixF& a = d.regression.weights[c];
    const MatrixF& b = e.regression.weights[c];
    ASSERT_EQ(a.rows(), b.rows());
    ASSERT_EQ(a.cols(), b.cols());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(float) * size_t(a.size())), 0) << "class " << c;
  }
  // Saved again: the same bytes.
  save_dictionary(e, tmp.path("e.tdic"));
  EXPECT_TRUE(file_bytes(tmp.path("d.tdic")) == file_bytes(tmp.path("e.tdic")));
  // Faithful amplification with the loaded dictionary: the same output, bit for bit, as with the
  // regression learned on the fly from the same exemplar (which is at the output's cell size).
  const Heightfield low = block_mean(rough_terrain(128, 96, 5.0, 4), 4);
  AmplifyOptions o;
  o.mode = "faithful";
  const Heightfield a = amplify(low, e, o);
  const Heightfield b = amplify_from_exemplars(low, {ex}, small_learn(), o);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.z.data(), b.z.data(), sizeof(float) * a.size()), 0);
  EXPECT_EQ(a.metadata.at("amplify_mode"), "faithful");
  const Heightfield m = block_mean(a, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-3f);
  // x16: the stored regression serves both steps.
  o.factor = 16;
  EXPECT_EQ(amplify(low, e, o).width, low.width * 16);
  // A cut in the regression's weights, or a corrupt regression header: clear errors, not a crash.
  std::string bytes = file_bytes(tmp.path("d.tdic"));
  std::string cut = bytes.substr(0, bytes.size() - 8 - 40);
  cut.resize(cut.size() + 8);
  rehash(cut);
  std::ofstream(tmp.path("cut.tdic"), std::ios::binary) << cut;
  EXPECT_THROW(
      {
        try {
          load_dictionary(tmp.path("cut.tdic"));
        } catch (const Error& err) {
          EXPECT_NE(std::string(err.what()).find("faithful regression"), std::string::npos) << err.what();
          throw;
        }
      },
      Error);
  const size_t reg_at = bytes.size() - 8 - 4 * size_t(e.regression.weights[0].size()) - 16;
  std::string bad = bytes;
  bad[reg_at] = 9;  // radius 9
  rehash(bad);
  std::ofstream(tmp.path("bad.tdic"), std::ios::binary) << bad;
  EXPECT_THROW(load_dictionary(tmp.path("bad.tdic")), Error);
}

TEST(AmplifyDictionary, VersionTwoFilesStillLoadWithoutRegression) {
  // A version 2 file is version 3 (here 4 without calibration) without the regression (flag bit 3
  // clear), with version = 2.
  test::TempDir tmp;
  LearnOptions l = small_learn();
  l.faithful_radius = 0;
  const Dictionary d = learn_dictionary({rough_terrain(96, 96, 5.0, 3)}, l);
  ASSERT_FALSE(d.has_regression());
  ASSERT_LT(d.spectral_scale, 0);
  save_dictionary(d, tmp.path("d.tdic"));
  std::string bytes = file_bytes(tmp.path("d.tdic"));
  ASSERT_EQ(bytes[4], 5);
  bytes[4] = 2;
  rehash(bytes);
  std::ofstream(tmp.path("v2.tdic"), std::ios::binary) << bytes;
  const Dictionary e = load_dictionary(tmp.path("v2.tdic"));
  EXPECT_TRUE(e.high == d.high);
  EXPECT_EQ(e.low_norm, d.low_norm);
  EXPECT_FALSE(e.has_regression());
  EXPECT_EQ(e.base, "bicubic");  // the base its gain was calibrated for before version 3
  // Faithful mode needs the regression: a clear error.
  AmplifyOptions o;
  o.mode = "faithful";
  try {
    amplify(block_mean(rough_terrain(64, 64, 5.0, 5), 4), e, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("no faithful regression"), std::string::npos) << err.what();
  }
}

TEST(AmplifyDictionary, CorruptFilesGiveClearErrors) {
  test::TempDir tmp;
  const Dictionary d = learn_dictionary({rough_terrain(48, 48, 5.0, 2)}, small_learn());
  save_dictionary(d, tmp.path("d.tdic"));
  std::string bytes;
  {
    std::ifstream f(tmp.path("d.tdic"), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  auto write = [&](const std::string& name, const std::string& b) {
    std::ofstream(tmp.path(name), std::ios::binary) << b;
    return tmp.path(name);
  };
  auto message = [](const std::string& p) {
    try {
      load_dictionary(p);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x55;
  EXPECT_NE(message(write("flip.tdic", flipped)).find("checksum"), std::string::npos);
  EXPECT_NE(message(write("short.tdic", bytes.substr(0, bytes.size() - 100))).find("truncated"), std::string::npos);
  EXPECT_NE(message(write("junk.tdic", "hello world")).find("not a terracl dictionary"), std::string::npos);
  EXPECT_NE(message(tmp.path("missing.tdic")).find("cannot open"), std::string::npos);
}

TEST(AmplifyAmplify, OutputIsGeoreferencedFinerAndConsistent) {
  const Heightfield ex = rough_terrain(96, 96, 5.0, 1);
  const Heightfield low = block_mean(rough_terrain(96, 64, 5.0, 8), 4);  // 20 m cells
  AmplifyOptions o;
  const Heightfield out = amplify_from_exemplars(low, {ex}, small_learn(), o);
  EXPECT_EQ(out.width, 96);
  EXPECT_EQ(out.height, 64);
  EXPECT_NEAR(out.georef.cell_x, 5.0, 1e-9);
  EXPECT_EQ(out.count_nodata(), 0u);
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
  // Detail was added: the output is rougher than bicubic.
  EXPECT_GT(roughness(out, 4), 1.3 * roughness(bicubic_upsample(low, 4), 4));
}

TEST(AmplifyAmplify, TilesGiveTheSameResultAsOneTile) {
  const Dictionary d = learn_dictionary({rough_terrain(64, 64, 5.0, 3)}, small_learn());
  const Heightfield low = block_mean(test::smooth_terrain(160, 136, 5.0, 300.0, 4), 4);
  AmplifyOptions o;
  o.tile = 4096;
  const Heightfield a = amplify(low, d, o);
  o.tile = 64;
  const Heightfield b = amplify(low, d, o);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a.z[i], b.z[i], 1e-3f);
  // Two steps (x16) with the same dictionary.
  o.factor = 16;
  const Heightfield c = amplify(block_mean(low, 4), d, o);
  EXPECT_EQ(c.width, low.width / 4 * 16);
}

TEST(AmplifyAmplify, FlannAndExactSearchAgreeWhenUnlimited) {
  LearnOptions l = small_learn();
  const Dictionary d = learn_dictionary({rough_terrain(64, 64, 5.0, 5)}, l);
  const Heightfield low = block_mean(test::smooth_terrain(64, 64, 5.0, 300.0, 6), 4);
  AmplifyOptions o;
  o.search = "exact";
  const Heightfield a = amplify(low, d, o);
  o.search = "flann";
  o.checks = -1;
  const Heightfield b = amplify(low, d, o);
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a.z[i], b.z[i], 1e-3f);
}

TEST(AmplifyAmplify, CandidatePoolVariesIdenticalFootprints) {
  // On a tilted plane every patch has the same footprint: the nearest atoms repeat with the patch
  // spacing (8 cells); drawing them from a larger pool by position breaks the repetition.
  const Dictionary d = learn_dictionary({rough_terrain(96, 96, 5.0, 21)}, small_learn());
  // 40 x 40 input cells, measured 16 or more from the borders (the band-limited base's 8-cell reach).
  Heightfield low(40, 40);
  low.georef.cell_x = low.georef.cell_y = 20.0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) low.at(x, y) = 2.0f * x + 1.0f * y;
  AmplifyOptions o;
  o.search = "exact";
  o.detail_gain = 1;
  auto periodic_error = [&](const Heightfield& h) {
    double e = 0;
    for (int y = 64; y < 96; ++y)
      for (int x = 64; x < 88; ++x) e = std::max(e, double(std::fabs(h.at(x + 8, y) - h.at(x, y) - 2.0f * 8 / 4)));
    return e;
  };
  EXPECT_LT(periodic_error(amplify(low, d, o)), 1e-2);
  o.candidates = 8;
  const Heightfield v = amplify(low, d, o);
  EXPECT_GT(periodic_error(v), 0.1);
  const Heightfield m = block_mean(v, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
}

TEST(AmplifyCalibration, GainMatchesHeldOutHfEnergyWithinTheRmseBudget) {
  // Independent check of the pooled 2-fold calibration: amplify each held-out strip for real with the
  // returned gain (bias correction on, not the affine shortcut) and pool the HF energies and errors.
  // Either the HF energy matches the truth's and the RMSE stays within the budget (1.14 x bicubic),
  // or the budget binds and the HF energy falls short.
  std::vector<bool> hf_bound;
  for (const Heightfield& ex : {read_heightfield(test::data_path("crops/presidential_128x96.tif")),
                                rough_terrain(160, 96, 5.0, 31, 4.f)}) {
    const LearnOptions l = small_learn();
    const GainCalibration cal = calibrate_detail(ex, l);
    const double g = cal.gain;
    ASSERT_TRUE(cal.calibrated);
    ASSERT_GT(g, 0.25);
    ASSERT_LT(g, 4.0);
    const int half = ex.width / 2, w = half / 4 * 4, h = ex.height / 4 * 4;
    double e_out = 0, e_bic = 0, hf_out = 0, hf_true = 0;
    for (int fold = 0; fold < 2; ++fold) {
      const Heightfield train = crop_of(ex, fold == 0 ? half : 0, 0, fold == 0 ? ex.width - half : half, ex.height);
      const Heightfield held = crop_of(ex, fold == 0 ? 0 : half, 0, w, h);
      const Dictionary d = learn_dictionary({train}, l);
      const Heightfield low = block_mean(held, 4);
      AmplifyOptions o;
      o.detail_gain = float(g);
      const Heightfield out = amplify(low, d, o);
      const Heightfield bic = bicubic_upsample(low, 4);
      for (size_t i = 0; i < out.size(); ++i) {
        e_out += double(out.z[i] - held.z[i]) * (out.z[i] - held.z[i]);
        e_bic += double(bic.z[i] - held.z[i]) * (bic.z[i] - held.z[i]);
      }
      hf_out += energy_above(out, 4), hf_true += energy_above(held, 4);
    }
    const double rmse_ratio = std::sqrt(e_out / e_bic), hf_ratio = hf_out / hf_true;
    EXPECT_NEAR(rmse_ratio, cal.rmse_ratio, 2e-3);
    EXPECT_NEAR(hf_ratio, cal.hf_ratio, 5e-3);
    hf_bound.push_back(std::fabs(hf_ratio - l.calibration_hf_target) <= 5e-3);
    if (hf_bound.back()) {
      EXPECT_LT(rmse_ratio, 1.14 + 2e-3);
    } else {
      EXPECT_NEAR(rmse_ratio, 1.14, 2e-3);
      EXPECT_LT(hf_ratio, l.calibration_hf_target);
    }
    EXPECT_EQ(g, calibrate_detail_gain(ex, l));  // reproducible
  }
  EXPECT_TRUE(hf_bound[0]);  // real terrain: as much fine relief as the held-out truth
}

TEST(AmplifyErrors, BadInputsAreReported) {
  const Heightfield ex = rough_terrain(64, 64, 5.0, 1);
  const Heightfield low = block_mean(test::smooth_terrain(64, 64, 5.0, 300.0, 2), 4);
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  AmplifyOptions o;
  o.factor = 8;
  EXPECT_NE(message([&] { amplify_from_exemplars(low, {ex}, small_learn(), o); }).find("factor 8 is not supported"),
            std::string::npos);
  o.factor = 4;
  EXPECT_NE(message([&] { amplify_from_exemplars(low, {rough_terrain(12, 40, 5.0, 1)}, small_learn(), o); })
                .find("smaller than one 16x16 patch"),
            std::string::npos);
  Heightfield coarse = ex;
  coarse.georef.cell_x = coarse.georef.cell_y = 7.0;  // output cells are 5 m
  EXPECT_NE(message([&] { amplify_from_exemplars(low, {coarse}, small_learn(), o); }).find("mismatched cell sizes"),
            std::string::npos);
  Heightfield odd = ex;
  odd.georef.cell_x = odd.georef.cell_y = 2.0;  // 5 m is 2.5 exemplar cells
  EXPECT_NE(message([&] { amplify_from_exemplars(low, {odd}, small_learn(), o); }).find("mismatched cell sizes"),
            std::string::npos);
  EXPECT_NE(message([&] { learn_dictionary({ex, coarse}, small_learn()); }).find("mismatched cell sizes"), std::string::npos);
  Heightfield flat(64, 64, 100.f);
  flat.georef.cell_x = flat.georef.cell_y = 5.0;
  EXPECT_NE(message([&] { learn_dictionary({flat}, small_learn()); }).find("flat"), std::string::npos);
}

TEST(AmplifyEncode, HigherSparsityGivesHigherPsnr) {
  const Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const EncodeReport a = encode_report(h, 1, 32, 8, 3);
  const EncodeReport b = encode_report(h, 4, 32, 8, 3);
  EXPECT_GT(b.psnr, a.psnr);
  EXPECT_GT(a.psnr, 20.0);
  EXPECT_GT(b.rho, a.rho);
  EXPECT_NEAR(a.rho, (64.0 * 32 + a.patches * 4 + 1) / h.size(), 1e-12);
}

TEST(AmplifyStyles, MaskSelectsTheDictionaryAndBlendsSmoothly) {
  const Dictionary gentle = learn_dictionary({rough_terrain(64, 64, 5.0, 1, 0.5f)}, small_learn());
  const Dictionary rugged = learn_dictionary({rough_terrain(64, 64, 5.0, 2, 12.f)}, small_learn());
  const Heightfield low = block_mean(rough_terrain(128, 64, 5.0, 3, 3.f), 4);
  Heightfield mask(low.width, low.height, 0.f);
  for (int y = 0; y < mask.height; ++y)
    for (int x = mask.width / 2; x < mask.width; ++x) mask.at(x, y) = 1.f;
  AmplifyOptions o;
  const Heightfield out = amplify_styles(low, {&gentle, &rugged}, mask, 4.0, o);
  auto half_roughness = [&](int x0, int x1) {
    Heightfield c(x1 - x0, out.height);
    for (int y = 0; y < out.height; ++y)
      for (int x = x0; x < x1; ++x) c.at(x - x0, y) = out.at(x, y);
    return roughness(c, 4);
  };
  EXPECT_GT(half_roughness(80, 128), 2.0 * half_roughness(0, 48));
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
  Heightfield wrong(3, 3);
  EXPECT_THROW(amplify_styles(low, {&gentle, &rugged}, wrong, 4.0, o), Error);
}
