// SPDX-License-Identifier: Apache-2.0
#pragma once
// One x f step of amplification over a window: each output patch's low-resolution footprint is
// matched against the dictionary's atoms (FLANN or exact search, or OMP for sparsity > 1), the same
// coefficients applied to the high-resolution atoms, and the patches blended with the disc weights.
// Internal to amplify_step.cpp and amplify_calibration.cpp.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace terracl::amplify_internal {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

// One row of a patch added to the blend's sums over its columns [u0, u1): num += w src, and den +=
// w^2, den1 += w (detail blend: `den1` given) or den += w; uv[2 u] += uv_sign w where `uv` is given.
void add_patch_row(const float* w, const float* src, int u0, int u1, float* num, float* den, float* den1, float* uv,
                   float uv_sign);

// The blend's sums over a window of output cells (StepEngine::blend): row-major, w x h, first cell
// (x0, y0) in the engine's local output coordinates.
struct BlendSums {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  std::vector<float> num, den, den1, uv;
};

// The blended detail at one cell: its weighted sum over the spread of the blend there (detail
// blend: details with pairwise correlation rho have var(sum w_i d_i) = sigma^2 ((1 - rho) sum w_i^2 +
// rho (sum w_i)^2); dividing by its square root keeps the detail's variance the same wherever the
// patches overlap (a partition of unity, sum w_i d_i / sum w_i, right for rho = 1 only, halves the
// variance of uncorrelated details between two patch centres and quarters it between four: a
// ripple with the spacing). Anisotropic details (delta != 0): x-neighbour overlaps correlate by
// rho + delta, y-neighbour ones by rho - delta (StepEngine::measure_rho); u, v as blend's uv.
inline float blended_value(float num, float den, float den1, float u, float v, float rho, float delta,
                           bool detail_blend, bool aniso) {
  const float norm = !detail_blend ? den
                     : aniso       ? std::sqrt((1 - rho) * den + rho * den1 * den1 + 2 * delta * u * v)
                                   : std::sqrt((1 - rho) * den + rho * den1 * den1);
  return num / norm;
}

// SplitMix64 finaliser of (seed, a, b, c): a reproducible per-patch random number.
inline uint64_t position_hash(uint64_t seed, int64_t a, int64_t b, int64_t c) {
  uint64_t z = seed * 0x9e3779b97f4a7c15ull + uint64_t(a) * 0xbf58476d1ce4e5b9ull + uint64_t(b) * 0x94d049bb133111ebull +
               uint64_t(c) * 0xd6e8feb86659fd93ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// One x f step over a window of the step's input whose first cell is the input's global cell
// (ox, oy). Every choice and every sum follows global output coordinates - which patches exist,
// their low-resolution footprints, the candidate draw (hashed on the patch's global index and the
// step), the order in which a cell's patches are added (by the global patch row's phase, then
// column) - so a window with enough halo (amplify_halo) gives the whole raster's cells bit for bit.
// Patch k covers output cells [k S - Q, k S - Q + P) globally; its footprint starts at (k S - Q) / f.
class StepEngine {
 public:
  StepEngine(const Heightfield& low, int ox, int oy, int step, const Dictionary& d, const AmplifyOptions& o,
             const AtomIndex* index)
      : m_low(low), m_ox(ox * d.factor), m_oy(oy * d.factor), m_step(step), m_d(d), m_o(o), m_index(index),
        f(d.factor), P(d.patch), p(d.low_patch()), S(o.spacing), Q(P - S), pm_(P / f),
        m_weights(patch_weights(P)), m_lmask(patch_mask(p)) {
    for (float m : m_lmask) m_lmsum += m;
    m_use_omp = o.sparsity > 1 || o.search == "omp";
    m_detail_blend = o.blend == "detail";
    // The smooth part M X M^T with M = U B (B: P/f x P block means, U = f M B^T: P x P/f bicubic),
    // computed as U (B X B^T) U^T: ~2.5k multiply-adds per patch instead of 8k for two P^3 products.
    m_bmat = MatrixF::Zero(pm_, P);
    for (int x = 0; x < pm_; ++x)
      for (int u = 0; u < f; ++u) m_bmat(x, x * f + u) = 1.f / f;
    m_umat = float(f) * smooth_part_operator(P, f, o.base) * m_bmat.transpose();
    // The magnitude term compares relief at the dictionary's cell size (self-similar scaling when a
    // dictionary serves a coarser step).
    const Georef g = low.georef.resampled(f);
    m_qscale = d.cell_x > 0 && g.cell_x > 0 ? float(d.cell_x / g.cell_x) : 1.f;
    // A later step of a cascade: its detail scaled by the relief of the exemplar's footprints over
    // this input's (relief_scale; AmplifyOptions::cascade_relief_exponent, docs/amplify.md,
    // "Relief scale of later cascade steps").
    if (m_detail_blend && (step > 0 || o.later_cascade_step) && o.cascade_relief_exponent != 0.f &&
        !d.low_norm.empty()) {
      const double b = o.cascade_relief_exponent > 0 ? o.cascade_relief_exponent : detail_relief_exponent(d, o.base);
      if (b > 0) {
        std::vector<float> n = d.low_norm;
        std::nth_element(n.begin(), n.begin() + long(n.size() / 2), n.end());
        m_qref = n[n.size() / 2];
        if (m_qref > 0) m_relief_b = float(b);
      }
    }
  }

  bool detail_blend() const { return m_detail_blend; }
  // The exponent b and reference norm q_ref of the relief scaling (0: off).
  float relief_exponent() const { return m_relief_b; }
  float relief_reference() const { return m_qref; }

  // The relief scale of a later cascade step, (q_ref / q_med)^b (1 when off): q_med the median
  // footprint norm (as the magnitude term scales it) of the patches over the output cells [X0, X1) x
  // [Y0, Y1) (local coordinates of a window that holds their footprints), at least 5 % of q_ref.
  // The atom search ties each patch's detail to its own footprint's relief as the exemplar's
  // patches do (detail ~ relief^(1 - b)); across terrains the fine relief follows the relief less,
  // so an input gentler than the exemplar gets more detail per footprint, a rougher one less. The
  // footprints are blend()'s (the same disc mask, mean and clamping).
  float relief_scale(int X0, int Y0, int X1, int Y1) const {
    if (!(m_relief_b > 0)) return 1.f;
    const int kx0 = first(m_ox + X0), kx1 = last(m_ox + X1), ky0 = first(m_oy + Y0), ky1 = last(m_oy + Y1);
    std::vector<float> norms;
    for (int ky = ky0; ky < ky1; ++ky)
      for (int kx = kx0; kx < kx1; ++kx) {
        const int lx = (kx * S - Q) / f - m_ox / f, ly = (ky * S - Q) / f - m_oy / f;
        double s = 0, s2 = 0;
        for (int v = 0; v < p; ++v)
          for (int u = 0; u < p; ++u)
            s += m_lmask[v * p + u] * m_low.at(clampi(lx + u, m_low.width), clampi(ly + v, m_low.height));
        const double mean = s / m_lmsum;
        for (int v = 0; v < p; ++v)
          for (int u = 0; u < p; ++u) {
            const double e = m_lmask[v * p + u] * (m_low.at(clampi(lx + u, m_low.width), clampi(ly + v, m_low.height)) - mean);
            s2 += e * e;
          }
        norms.push_back(float(std::sqrt(s2)) * m_qscale);
      }
    if (norms.empty()) return 1.f;
    std::nth_element(norms.begin(), norms.begin() + long(norms.size() / 2), norms.end());
    const float q = std::max(norms[norms.size() / 2], 0.05f * m_qref);
    return std::pow(m_qref / q, m_relief_b);
  }

  // Sums of the blend over the local output cells [X0, X1) x [Y0, Y1): num, den (sum w^2 for the
  // detail blend, else sum w) and den1 (sum w, detail blend only); `uv` (detail blend with at most
  // two patches per axis over a cell, anisotropic()): per cell, u = w00 - w11 and v = w10 - w01, the
  // weights of its patches by the parity of their global column and row (a cell has at most one
  // patch of each), so 2 u v = (x-neighbour products) - (y-neighbour products) of the weights.
  void blend(int X0, int Y0, int X1, int Y1, std::vector<float>& num, std::vector<float>& den,
             std::vector<float>& den1, std::vector<float>* uv = nullptr) const {
    const int gx0 = m_ox + X0, gy0 = m_oy + Y0;
    const int kx0 = first(gx0), kx1 = last(m_ox + X1), ky0 = first(gy0), ky1 = last(m_oy + Y1);
    const int nx = kx1 - kx0, ny = ky1 - ky0;
    const size_t m = size_t(nx) * ny;
    const int tw = X1 - X0, th = Y1 - Y0;
    num.assign(size_t(tw) * th, 0.f);
    den.assign(num.size(), 0.f);
    den1.assign(m_detail_blend ? num.size() : 0, 0.f);
    const bool with_uv = uv && anisotropic();
    if (uv) uv->assign(with_uv ? 2 * num.size() : 0, 0.f);
    if (m == 0) return;
    std::vector<float> z(m);
    MatrixF q(p * p, Eigen::Index(m));
    parallel_for(m, m_o.threads, [&](size_t b, size_t e) {
      for (size_t c = b; c < e; ++c) {
        const int lx = ((kx0 + int(c % nx)) * S - Q) / f - m_ox / f, ly = ((ky0 + int(c / nx)) * S - Q) / f - m_oy / f;
        double s = 0;
        for (int v = 0; v < p; ++v)
          for (int u = 0; u < p; ++u)
            s += m_lmask[v * p + u] * m_low.at(clampi(lx + u, m_low.width), clampi(ly + v, m_low.height));
        const float mean = float(s / m_lmsum);
        for (int v = 0; v < p; ++v)
          for (int u = 0; u < p; ++u)
            q(v * p + u, Eigen::Index(c)) =
                m_lmask[v * p + u] * (m_low.at(clampi(lx + u, m_low.width), clampi(ly + v, m_low.height)) - mean);
        z[c] = mean;
      }
    });
    SparseCodes codes;
    if (m_use_omp) {
      codes = batch_omp(m_d.low, q, m_o.sparsity, m_o.threads);
    } else {
      // k nearest atoms averaged: their shared detail adds up, the rest partly cancels. With a
      // larger candidate pool, each patch draws its k from the pool by a hash of its position, so
      // that equal footprints (straight painted edges) do not repeat the same detail.
      const int k = std::max(1, m_o.neighbours), pool = std::max(k, m_o.candidates);
      AtomMatch a = m_index ? m_index->search(q, m_o.threads, pool, m_qscale)
                            : exact_atom_search(m_d.low, q, m_o.threads, pool, &m_d.low_norm, m_o.magnitude_weight,
                                                m_qscale);
      codes.sparsity = k;
      codes.index.assign(m * size_t(k), -1);
      codes.coef.assign(m * size_t(k), 0.f);
      for (size_t c = 0; c < m; ++c) {
        int32_t* idx = &a.index[c * pool];
        float* coef = &a.coef[c * pool];
        int found = 0;
        while (found < pool && idx[found] >= 0) ++found;
        if (found > k) {
          // Hashed on the patch's global index and the step (not on the output's size): a tile
          // draws what the whole raster draws.
          uint64_t h = position_hash(m_o.seed, m_step + 1, kx0 + int(c % nx), ky0 + int(c / nx));
          for (int t = 0; t < k; ++t) {  // partial Fisher-Yates
            h = position_hash(h, t, 0, 0);
            const int r = t + int(h % uint64_t(found - t));
            std::swap(idx[t], idx[r]);
            std::swap(coef[t], coef[r]);
          }
          found = k;
        }
        for (int t = 0; t < found; ++t) {
          codes.index[c * k + t] = idx[t];
          codes.coef[c * k + t] = coef[t] / float(found);
        }
      }
    }
    const int s = codes.sparsity;
    const int phases = (P + S - 1) / S;  // patch rows this far apart never overlap
    // A cell's patches are added phase by phase of their global row (then by column): the same
    // order in every window.
    for (int ph = 0; ph < phases; ++ph) {
      std::vector<int> rows;
      for (int r = 0; r < ny; ++r)
        if ((ky0 + r) % phases == ph) rows.push_back(r);
      parallel_for(rows.size(), m_o.threads, [&](size_t b, size_t e) {
        VectorF patch(P * P);
        MatrixF detail(P, P), bx(pm_, P), cm(pm_, pm_), ucm(P, pm_);
        for (size_t ri = b; ri < e; ++ri) {
          const int r = rows[ri];
          for (int cx = 0; cx < nx; ++cx) {
            const size_t c = size_t(r) * nx + cx;
            const int px = (kx0 + cx) * S - Q - gx0, py = (ky0 + r) * S - Q - gy0;
            // parity class of the patch: (0,0) +u, (1,1) -u, (1,0) +v, (0,1) -v
            const int cls = ((kx0 + cx) & 1) + 2 * ((ky0 + r) & 1);
            const int uv_off = cls == 0 || cls == 3 ? 0 : 1;
            const float uv_sign = cls == 0 || cls == 1 ? 1.f : -1.f;
            // The patch (its atoms combined once), then its weighted blend.
            patch.setConstant(z[c]);
            for (int t = 0; t < s; ++t) {
              const int a = codes.index[c * s + t];
              if (a >= 0) patch += codes.coef[c * s + t] * m_d.high.col(a);
            }
            if (m_detail_blend) {
              // Only the patch's detail (what its block means do not determine) is blended; the
              // bicubic of the input supplies the rest.
              Eigen::Map<MatrixF> pmap(patch.data(), P, P);
              bx.noalias() = m_bmat * pmap;  // preallocated: no allocation per patch
              cm.noalias() = bx * m_bmat.transpose();
              ucm.noalias() = m_umat * cm;
              detail = pmap;
              detail.noalias() -= ucm * m_umat.transpose();
            }
            const float* src = m_detail_blend ? detail.data() : patch.data();
            // Row runs of the patch inside the window. A zero weight adds exactly nothing to a
            // finite sum, so the runs need no per-cell test and vectorise.
            const int u0 = std::max(0, -px), u1 = std::min(P, tw - px);
            for (int v = std::max(0, -py); v < P && py + v < th; ++v) {
              const size_t o2 = size_t(py + v) * tw + px;
              add_patch_row(m_weights.data() + v * P, src + v * P, u0, u1, num.data() + o2, den.data() + o2,
                            m_detail_blend ? den1.data() + o2 : nullptr,
                            with_uv ? uv->data() + 2 * o2 + uv_off : nullptr, uv_sign);
            }
          }
        }
      });
    }
  }

  // Whether the blend can tell x- from y-neighbour overlaps (blend's uv): at most two patches per
  // axis over a cell.
  bool anisotropic() const { return m_detail_blend && P <= 2 * S; }

  // Detail blend: the correlation rho measured on the output cells [X0, X1) x [Y0, Y1) (local
  // coordinates of a window that holds them with their footprint): for candidate correlations, the
  // squared curvature of the blended detail per phase of the patch grid (the weights repeat with the
  // spacing); rho makes it the same at every phase (the evaluation's periodic trace). Then, at that
  // rho, the anisotropy delta (anisotropic() only, else 0): overlaps of x-neighbours are given the
  // correlation rho + delta, of y-neighbours rho - delta (diagonal ones rho), |delta| <= min(rho, 1 -
  // rho), chosen by the same flatness. Details of anisotropic terrain (the Front Range's north-south
  // ridges) are correlated more along one axis than the other, which one rho cannot fit: its
  // compromise left a ripple with the spacing along y (docs/amplify.md).
  // `keep`: the blend's sums over the measured cells and their one-cell margin, for the caller.
  std::pair<float, float> measure_rho(int X0, int Y0, int X1, int Y1, BlendSums* keep = nullptr) const {
    // Band-limited base: rho flattens the curvature of base + 2 detail per phase (2: a typical
    // calibrated gain, fixed so that the output stays affine in the gain, as the calibration needs). The
    // bicubic base's knots have a phase pattern of their own that the detail partly offsets; there
    // rho flattens the detail alone (measuring the output as well moved no figure: docs/amplify.md).
    const bool measure_output = m_o.base == "bandlimited";
    constexpr int kRhos = 11;
    constexpr double kRhoGain = 2.0;
    // One cell of margin for the Laplacian, where the window has it.
    const int W = m_low.width * f, H = m_low.height * f;
    const int bx0 = std::max(0, X0 - 1), by0 = std::max(0, Y0 - 1), bx1 = std::min(W, X1 + 1), by1 = std::min(H, Y1 + 1);
    std::vector<float> num, den, den1, uv;
    blend(bx0, by0, bx1, by1, num, den, den1, &uv);
    const int tw = bx1 - bx0, th = by1 - by0;
    auto done = [&](float rho, float delta) {
      if (keep) *keep = BlendSums{bx0, by0, tw, th, std::move(num), std::move(den), std::move(den1), std::move(uv)};
      return std::pair<float, float>{rho, delta};
    };
    // The flatness (coefficient of variation over the S x S phases of the squared curvature) of the
    // output for kRhos candidate normalisations: var(t, c) is the blend's variance at local cell c.
    auto flatness = [&](const std::function<float(int, size_t)>& var) {
      std::vector<double> phase_k2(size_t(kRhos) * S * S, 0.0), phase_n(size_t(S) * S, 0.0);
      // One band of S rows in four (by the global row, every phase of the grid) is enough. Rows in
      // parallel, each into its own sums, added in row order: rho does not depend on the threads.
      std::vector<double> row_k2(size_t(th) * kRhos * S, 0.0), row_n(size_t(th) * S, 0.0);
      parallel_for(size_t(th), m_o.threads, [&](size_t b, size_t e) {
        // Three slots, each one row blended for every candidate; consecutive rows y share two of
        // their three, so each row is blended once.
        std::vector<double> bl(size_t(3) * kRhos * tw);
        std::vector<float> base_row(measure_output ? size_t(tw) : 0);  // the base there
        int slot_row[3] = {-1, -1, -1};
        auto slot_of = [&](int row) {
          for (int k = 0; k < 3; ++k)
            if (slot_row[k] == row) return k;
          return -1;
        };
        for (size_t yy = b; yy < e; ++yy) {
          const int y = int(yy), gy = m_oy + by0 + y;
          if (y < 1 || y + 1 >= th || by0 + y < Y0 || by0 + y >= Y1 || (gy / S) % 4 != 0) continue;
          if (gy % 64 == 0 || gy % 64 == 63) continue;
          int slot[3];
          for (int dy = 0; dy < 3; ++dy) slot[dy] = slot_of(y - 1 + dy);
          for (int dy = 0; dy < 3; ++dy) {
            if (slot[dy] >= 0) continue;
            int k = 0;  // a slot holding none of rows y-1..y+1 (one is free: three slots, three rows)
            while (slot_row[k] >= y - 1 && slot_row[k] <= y + 1) ++k;
            slot[dy] = k;
            slot_row[k] = y - 1 + dy;
            if (measure_output) upsample_window(m_low, f, m_o.base, bx0, by0 + y - 1 + dy, tw, 1, base_row.data());
            for (int x = 0; x < tw; ++x) {
              const size_t c = size_t(y - 1 + dy) * tw + x;
              for (int t = 0; t < kRhos; ++t) {
                const double v = double(num[c]) / std::sqrt(var(t, c));
                bl[(size_t(k) * kRhos + t) * tw + x] = measure_output ? base_row[size_t(x)] + kRhoGain * v : v;
              }
            }
          }
          double* k2 = &row_k2[size_t(y) * kRhos * S];
          double* n = &row_n[size_t(y) * S];
          for (int x = 1; x + 1 < tw; ++x) {
            const int gx = m_ox + bx0 + x;
            if (bx0 + x < X0 || bx0 + x >= X1 || gx % 64 == 0 || gx % 64 == 63) continue;
            const int ph = gx % S;
            n[ph] += 1;
            for (int t = 0; t < kRhos; ++t) {
              const double* r0 = &bl[(size_t(slot[0]) * kRhos + t) * tw];
              const double* r1 = &bl[(size_t(slot[1]) * kRhos + t) * tw];
              const double* r2 = &bl[(size_t(slot[2]) * kRhos + t) * tw];
              const double lap = double(r1[x - 1]) + r1[x + 1] + r0[x] + r2[x] - 4.0 * r1[x];
              k2[size_t(t) * S + ph] += lap * lap;
            }
          }
        }
      });
      for (int y = 0; y < th; ++y) {
        const size_t py = size_t((m_oy + by0 + y) % S) * S;
        for (int ph = 0; ph < S; ++ph) {
          phase_n[py + ph] += row_n[size_t(y) * S + ph];
          for (int t = 0; t < kRhos; ++t)
            phase_k2[size_t(t) * phase_n.size() + py + ph] += row_k2[(size_t(y) * kRhos + t) * S + ph];
        }
      }
      std::vector<double> cv(kRhos, 0.0);
      for (int t = 0; t < kRhos; ++t) {
        double s = 0, s2 = 0, n = 0;
        for (size_t k = 0; k < phase_n.size(); ++k) {
          if (phase_n[k] == 0) continue;
          const double e = phase_k2[size_t(t) * phase_n.size() + k] / phase_n[k];
          s += e, s2 += e * e, n += 1;
        }
        cv[size_t(t)] = n > 1 && s > 0 ? (s2 / n - (s / n) * (s / n)) / ((s / n) * (s / n)) : 0;
      }
      // The candidate with the flattest profile, refined by a parabola through it and its neighbours:
      // its position t / (kRhos - 1) in [0, 1].
      const int t = int(std::min_element(cv.begin(), cv.end()) - cv.begin());
      double r = double(t) / (kRhos - 1);
      if (t > 0 && t < kRhos - 1) {
        const double a = cv[size_t(t - 1)], b = cv[size_t(t)], c = cv[size_t(t + 1)], dd = a - 2 * b + c;
        if (dd > 0) r += std::clamp(0.5 * (a - c) / dd, -0.5, 0.5) / (kRhos - 1);
      }
      return r;
    };
    const float rho = float(flatness([&](int t, size_t c) {
      const float r = float(t) / (kRhos - 1);
      return (1 - r) * den[c] + r * den1[c] * den1[c];
    }));
    const double span = std::min(rho, 1.f - rho);
    if (!m_o.detail_anisotropy || !anisotropic() || !(span > 0)) return done(rho, 0.f);
    // delta = span (2 q - 1) for q = t / (kRhos - 1) in [0, 1]: from -span to +span, 0 in the middle.
    auto delta_of = [&](double q) { return float(span * (2 * q - 1)); };
    const float delta = delta_of(flatness([&](int t, size_t c) {
      const float r = rho, d = delta_of(double(t) / (kRhos - 1));
      return (1 - r) * den[c] + r * den1[c] * den1[c] + 2 * d * uv[2 * c] * uv[2 * c + 1];
    }));
    return done(rho, delta);
  }

 private:
  // First patch whose cells reach past global output cell a; first patch starting at or after b.
  int first(int a) const { return std::max(0, a / S); }
  int last(int b) const { return (b + Q + S - 1) / S; }

  const Heightfield& m_low;
  const int m_ox, m_oy, m_step;  // global output cell of the window's first output cell; step index
  const Dictionary& m_d;
  const AmplifyOptions& m_o;
  const AtomIndex* m_index;
  const int f, P, p, S, Q, pm_;
  const std::vector<float> m_weights, m_lmask;
  double m_lmsum = 0;
  bool m_use_omp = false, m_detail_blend = false;
  MatrixF m_bmat, m_umat;
  float m_qscale = 1.f;
  float m_relief_b = 0.f, m_qref = 0.f;
};

}  // namespace terracl::amplify_internal
