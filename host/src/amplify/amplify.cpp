// Amplification by a multi-resolution dictionary (sparse terrain paper, section 5.3): each output
// patch's low-resolution footprint is decomposed over L, the same coefficients applied to H, and the
// patches blended with the disc weights; then the block means are corrected to match the input.
// The output is produced tile by tile (only the tile's patches, codes and blend buffers are held).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <numeric>

namespace terracl {

namespace {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

// SplitMix64 finaliser of (seed, a, b, c): a reproducible per-patch random number.
uint64_t position_hash(uint64_t seed, int64_t a, int64_t b, int64_t c) {
  uint64_t z = seed * 0x9e3779b97f4a7c15ull + uint64_t(a) * 0xbf58476d1ce4e5b9ull + uint64_t(b) * 0x94d049bb133111ebull +
               uint64_t(c) * 0xd6e8feb86659fd93ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

int steps_for(int factor, int f) {
  int steps = 0, v = 1;
  while (v < factor && steps < 8) v *= f, ++steps;
  if (v != factor || factor < f)
    fail("amplify", "factor {} is not supported: use a power of {} ({}, {}, {}, {})", factor, f, f, f * f, f * f * f,
         f * f * f * f);
  return steps;
}

void check_options(const AmplifyOptions& o, const Dictionary& d) {
  if (o.spacing < d.factor || o.spacing % d.factor != 0 || o.spacing > d.patch)
    fail("amplify", "spacing {} must be a multiple of {} between {} and the patch size {}", o.spacing, d.factor,
         d.factor, d.patch);
  if (o.sparsity < 1) fail("amplify", "sparsity must be >= 1");
  if (o.tile < 64) fail("amplify", "tile must be >= 64 cells");
  if (o.neighbours < 0 || o.neighbours > 64) fail("amplify", "neighbours must be between 1 and 64, or 0 for the dictionary's (got {})", o.neighbours);
  if (o.candidates < 0 || o.candidates > 256) fail("amplify", "candidates must be between 0 and 256 (got {})", o.candidates);
  if (!(o.magnitude_weight < 1e6)) fail("amplify", "magnitude weight must be finite (got {})", o.magnitude_weight);
  if (o.mode != "detail" && o.mode != "faithful") fail("amplify", "mode '{}' is not one of detail|faithful", o.mode);
  if (o.base != "bicubic" && o.base != "bandlimited" && o.base != "auto")
    fail("amplify", "base '{}' is not one of bicubic|bandlimited|auto", o.base);
  if (o.blend != "detail" && o.blend != "average" && o.blend != "auto")
    fail("amplify", "blend '{}' is not one of detail|average|auto", o.blend);
  if (o.search != "auto" && o.search != "flann" && o.search != "exact" && o.search != "omp")
    fail("amplify", "search '{}' is not one of auto|flann|exact|omp", o.search);
}

// The dictionary's search settings where the options leave them open (its gain was calibrated for them).
AmplifyOptions resolved(AmplifyOptions o, const Dictionary& d) {
  if (o.neighbours <= 0) o.neighbours = d.neighbours;
  if (o.magnitude_weight < 0) o.magnitude_weight = d.magnitude_weight;
  if (o.blend == "auto") o.blend = d.blend;
  if (o.base == "auto") o.base = d.base;
  o.detail_anisotropy = o.detail_anisotropy && d.anisotropy;  // as the gain was calibrated
  return o;
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
    // this input's (relief_scale; AmplifyOptions::cascade_relief_exponent, docs/amplify.md, issue 16
    // session 10).
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
            for (int v = std::max(0, -py); v < P && py + v < th; ++v)
              for (int u = std::max(0, -px); u < P && px + u < tw; ++u) {
                const int k = v * P + u;
                const float w = m_weights[k];
                if (w == 0.f) continue;
                const size_t o2 = size_t(py + v) * tw + px + u;
                num[o2] += w * src[k];
                den[o2] += m_detail_blend ? w * w : w;
                if (m_detail_blend) den1[o2] += w;
                if (with_uv) (*uv)[2 * o2 + uv_off] += uv_sign * w;
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
  // compromise left a ripple with the spacing along y (docs/amplify.md, issue 16 session 8).
  std::pair<float, float> measure_rho(int X0, int Y0, int X1, int Y1) const {
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
    // The flatness (coefficient of variation over the S x S phases of the squared curvature) of the
    // output for kRhos candidate normalisations: var(t, c) is the blend's variance at local cell c.
    auto flatness = [&](const std::function<float(int, size_t)>& var) {
      std::vector<double> phase_k2(size_t(kRhos) * S * S, 0.0), phase_n(size_t(S) * S, 0.0);
      // One band of S rows in four (by the global row, every phase of the grid) is enough. Rows in
      // parallel, each into its own sums, added in row order: rho does not depend on the threads.
      std::vector<double> row_k2(size_t(th) * kRhos * S, 0.0), row_n(size_t(th) * S, 0.0);
      parallel_for(size_t(th), m_o.threads, [&](size_t b, size_t e) {
        std::vector<double> bl(size_t(3) * kRhos * tw);  // rows y-1, y, y+1 blended for every candidate
        std::vector<float> base_rows(measure_output ? size_t(3) * tw : 0);  // the base there
        for (size_t yy = b; yy < e; ++yy) {
          const int y = int(yy), gy = m_oy + by0 + y;
          if (y < 1 || y + 1 >= th || by0 + y < Y0 || by0 + y >= Y1 || (gy / S) % 4 != 0) continue;
          if (gy % 64 == 0 || gy % 64 == 63) continue;
          if (measure_output) upsample_window(m_low, f, m_o.base, bx0, by0 + y - 1, tw, 3, base_rows.data());
          for (int dy = 0; dy < 3; ++dy)
            for (int x = 0; x < tw; ++x) {
              const size_t c = size_t(y - 1 + dy) * tw + x;
              for (int t = 0; t < kRhos; ++t) {
                const double v = double(num[c]) / std::sqrt(var(t, c));
                bl[(size_t(dy) * kRhos + t) * tw + x] = measure_output ? base_rows[size_t(dy) * tw + x] + kRhoGain * v : v;
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
              const double* r0 = &bl[(size_t(0) * kRhos + t) * tw];
              const double* r1 = &bl[(size_t(1) * kRhos + t) * tw];
              const double* r2 = &bl[(size_t(2) * kRhos + t) * tw];
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
    if (!m_o.detail_anisotropy || !anisotropic() || !(span > 0)) return {rho, 0.f};
    // delta = span (2 q - 1) for q = t / (kRhos - 1) in [0, 1]: from -span to +span, 0 in the middle.
    auto delta_of = [&](double q) { return float(span * (2 * q - 1)); };
    const float delta = delta_of(flatness([&](int t, size_t c) {
      const float r = rho, d = delta_of(double(t) / (kRhos - 1));
      return (1 - r) * den[c] + r * den1[c] * den1[c] + 2 * d * uv[2 * c] * uv[2 * c + 1];
    }));
    return {rho, delta};
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

// Bounds of the relief scale of a later cascade step (amplify_step).
constexpr float kMinReliefScale = 0.5f, kMaxReliefScale = 2.f;

// The output of one step over the window `low` (first cell: the step input's global cell ox, oy),
// with the detail blend's correlation rho (detail blend only).
// `input_gain` > 0: the gain chosen for this input (input_hf_gain) where the options leave it open;
// `raw`: the blended detail only (no gain, base or bias correction), what input_hf_gain measures.
Heightfield amplify_step(const Heightfield& low, int ox, int oy, int step, float rho, float delta, const Dictionary& d,
                         const AmplifyOptions& o, const AtomIndex* index, const Progress& progress,
                         float input_gain = -1, float relief = 1, bool raw = false) {
  const int f = d.factor, S = o.spacing;
  const int W = low.width * f, H = low.height * f;
  Heightfield out(W, H);
  out.georef = low.georef.resampled(f);
  out.metadata = low.metadata;
  const StepEngine eng(low, ox, oy, step, d, o, index);
  const bool detail_blend = eng.detail_blend();
  // Work tiles bound the memory of codes and sums; no result depends on them.
  const int tile_unit = std::lcm(S, 64), tile = std::max(tile_unit, o.tile / tile_unit * tile_unit);
  const int tx = (W + tile - 1) / tile, ty = (H + tile - 1) / tile;
  std::vector<float> num, den, den1, uv;
  const bool aniso = detail_blend && delta != 0.f && eng.anisotropic();
  for (int j = 0; j < ty; ++j)
    for (int i = 0; i < tx; ++i) {
      const int X0 = i * tile, X1 = std::min(W, X0 + tile), Y0 = j * tile, Y1 = std::min(H, Y0 + tile);
      eng.blend(X0, Y0, X1, Y1, num, den, den1, aniso ? &uv : nullptr);
      const int tw = X1 - X0, th = Y1 - Y0;
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const float dn = den[size_t(y) * tw + x];
          if (!(dn > 0)) fail("amplify", "spacing {} leaves cells uncovered by {}-cell patches", S, d.patch);
          // Detail blend: details with pairwise correlation rho have var(sum w_i d_i) = sigma^2 ((1 - rho)
          // sum w_i^2 + rho (sum w_i)^2); dividing by its square root keeps the detail's variance the
          // same wherever the patches overlap (a partition of unity, sum w_i d_i / sum w_i, right for
          // rho = 1 only, halves the variance of uncorrelated details between two patch centres and
          // quarters it between four: a ripple with the spacing).
          const size_t c = size_t(y) * tw + x;
          // Anisotropic details (delta != 0): x-neighbour overlaps correlate by rho + delta, y-neighbour
          // ones by rho - delta (StepEngine::measure_rho).
          const float norm = !detail_blend ? dn
                             : aniso ? std::sqrt((1 - rho) * dn + rho * den1[c] * den1[c] + 2 * delta * uv[2 * c] * uv[2 * c + 1])
                                     : std::sqrt((1 - rho) * dn + rho * den1[c] * den1[c]);
          out.at(X0 + x, Y0 + y) = num[c] / norm;
        }
      report_progress(progress, "amplify", double(j * tx + i + 1) / (tx * ty), fmt::format("tile {}/{}", j * tx + i + 1, tx * ty));
    }
  if (raw) return out;
  if (detail_blend)
    out.metadata["amplify_detail_correlation"] =
        aniso ? fmt::format("{:.3f} (x {:.3f}, y {:.3f})", rho, rho + delta, rho - delta) : fmt::format("{:.3f}", rho);
  // A later cascade step's relief scale (StepEngine::relief_scale) multiplies whichever gain applies,
  // within [1/2, 2]: a mostly flat input (a painted sketch's plateaus) has a median footprint near 0.
  const float applied = detail_blend && relief > 0 ? std::clamp(relief, kMinReliefScale, kMaxReliefScale) : 1.f;
  const float gain = (o.detail_gain >= 0 ? o.detail_gain : input_gain > 0 ? input_gain : d.detail_gain) * applied;
  out.metadata["amplify_detail_gain"] = fmt::format("{:.3f}", gain);
  if (detail_blend && relief > 0 && relief != 1.f && eng.relief_exponent() > 0) {
    const float b = eng.relief_exponent(), qref = eng.relief_reference();
    std::string& note = out.metadata["amplify_relief_scale"];
    note += fmt::format("{}step {}: detail x {:.3f}{} = (q_ref {:.1f} m / median footprint {:.1f} m)^{:.3f}{}",
                        note.empty() ? "" : " | ", std::max(step + 1, o.later_cascade_step ? 2 : 1), applied,
                        applied != relief ? fmt::format(" (clamped from {:.3f})", relief) : "", qref,
                        qref * std::pow(relief, -1.f / b), b,
                        o.cascade_relief_exponent > 0 ? "" : " (b from the dictionary's atoms)");
  }
  if (detail_blend) {
    // out = bicubic + gain detail
    if (gain != 1.f)
      for (auto& v : out.z) v *= gain;
    add_upsampled(out, low, f, 1.f, o.base);
  } else if (gain != 1.f) {
    // out = base + gain (out - base)
    for (auto& v : out.z) v *= gain;
    add_upsampled(out, low, f, 1.f - gain, o.base);
  }
  if (o.bias_correction) correct_block_means(out, low, f, 4, o.base);
  return out;
}

// Input cells a step's output cell depends on, on each side: the patches' footprints (a cell's
// patches start up to P - 1 cells before it), the base's taps, and the bias correction's passes
// (each spreads block residuals over the base's taps again, plus the final block shift).
int step_halo(const Dictionary& d, const AmplifyOptions& o) {
  const int f = d.factor;
  const int patches = (d.patch + f - 1) / f + d.low_patch() + 1;
  const int base = upsample_reach(f, o.base);
  return std::max(patches, base) + (o.bias_correction ? 5 * base + 1 : 0) + 1;
}

// The measured region of a step's input (global cells): its central kRhoRegion x kRhoRegion
// cells, corner a multiple of 16 (the whole input when smaller).
constexpr int kRhoRegion = 256;
struct Rect {
  int x0, y0, x1, y1;
};
Rect rho_region(int w, int h) {
  auto axis = [](int n, int& a0, int& a1) {
    a0 = n > kRhoRegion ? (n - kRhoRegion) / 2 / 16 * 16 : 0;
    a1 = std::min(n, a0 + kRhoRegion);
  };
  Rect r{};
  axis(w, r.x0, r.x1);
  axis(h, r.y0, r.y1);
  return r;
}

constexpr int kMinSpectralInput = 64;

// Per-input HF calibration (docs/amplify.md, "per-input HF"): the gain whose output HF energy, on
// the first step's measured region (rho_region: the central (up to) 256 x 256 input cells, here
// cells [lx0, lx0 + cw) x [ly0, ly0 + ch) of the window `low`), is the geometric mean of two estimates of the truth's:
// the held-out folds' (the output's HF at the dictionary's HF-matching gain over its HF target) and
// the input's own spectrum extrapolated (predicted_energy_above, scaled by the ratio the folds
// measured). Their errors are independent (the folds know the dictionary, the spectrum knows this
// terrain). Capped by the folds' RMSE-budget gain. `detail` is the window's blended detail before
// the gain (amplify_step's raw output); -1 when the dictionary carries no in-memory calibration
// (loaded files) or the region is too small. A function of the whole input only: tiled and untiled
// runs get the same gain.
double input_hf_gain(const Heightfield& low, int lx0, int ly0, int cw, int ch, const Heightfield& detail,
                     const Dictionary& d, const std::string& base) {
  if (!(d.spectral_scale > 0) || !(d.hf_gain > 0) || !(d.hf_target > 0) || !(d.rmse_gain > 0)) return -1;
  const int f = d.factor;
  // Smaller inputs leave too few bins in the octave for the fit (a 23 x 47 input, the Front Range at
  // x16, gave 0.06 x the held-out estimate).
  if (cw < kMinSpectralInput || ch < kMinSpectralInput) return -1;
  Heightfield lowc(cw, ch);
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x) lowc.at(x, y) = low.at(lx0 + x, ly0 + y);
  const double pred = predicted_energy_above(lowc, f);
  if (!(pred > 0)) return -1;
  // cb = C(base), cd = C(base + detail) - cb on the crop (C: the bias correction, affine).
  Heightfield cb(cw * f, ch * f), cd(cw * f, ch * f);
  upsample_window(low, f, base, lx0 * f, ly0 * f, cw * f, ch * f, cb.z.data());
  for (int y = 0; y < ch * f; ++y)
    for (int x = 0; x < cw * f; ++x) cd.at(x, y) = cb.at(x, y) + detail.at(lx0 * f + x, ly0 * f + y);
  correct_block_means(cb, lowc, f, 4, base);
  correct_block_means(cd, lowc, f, 4, base);
  for (size_t j = 0; j < cd.z.size(); ++j) cd.z[j] -= cb.z[j];
  const auto sb = spectrum_above(cb, f), sd = spectrum_above(cd, f);
  double hb = 0, hbd = 0, hd = 0;
  for (size_t j = 0; j < sb.size(); ++j)
    hb += std::norm(sb[j]), hbd += std::real(sb[j] * std::conj(sd[j])), hd += std::norm(sd[j]);
  if (!(hd > 0)) return -1;
  const double gh = d.hf_gain;
  const double held_out = (hb + 2 * gh * hbd + gh * gh * hd) / d.hf_target, spectral = d.spectral_scale * pred;
  const double target = std::sqrt(held_out * spectral);
  const double disc = hbd * hbd - hd * (hb - target);
  double g = disc > 0 ? (-hbd + std::sqrt(disc)) / hd : gh;
  return std::clamp(g, 0.25, std::min(4.0, d.rmse_gain));
}

// Correlations rho of every step (detail blend; empty otherwise), each measured on its step's
// rho_region: the input of step k > 0 there is the previous steps' output over that region's
// footprint, amplified from a window of the input with the rhos found so far. Then the gain per step
// chosen for this input (input_hf_gain: the first step of a cascade only, `first_is_input`; -1 for
// the dictionary's or the options' gain), then the anisotropy delta per step (measure_rho; 0 with a
// fixed rho): the result holds `steps` rhos, `steps` gains, `steps` deltas. A function of the whole
// input only, so tiles and the untiled run use the same values.
std::vector<float> step_correlations(const AmplifyWindowReader& read, int width, int height, int steps,
                                     const Dictionary& d, const AmplifyOptions& o, const AtomIndex* index,
                                     bool first_is_input = true) {
  std::vector<float> rhos, gains(size_t(steps), -1.f), deltas(size_t(steps), 0.f), reliefs(size_t(steps), 1.f);
  if (o.blend != "detail") return rhos;
  // Later steps of a cascade get a relief scale (StepEngine::relief_scale).
  auto later = [&](int k) { return k > 0 || o.later_cascade_step; };
  const bool relief = o.cascade_relief_exponent != 0.f && !d.low_norm.empty() && (steps > 1 || o.later_cascade_step);
  const bool fixed_rho = o.detail_correlation >= 0;
  // Only the first step of a cascade sees measured terrain: later steps' inputs carry the previous
  // step's synthesized spectrum (at x16 on the Front Range its RMSE-capped gain made the second
  // step's estimate 0.55 x the held-out one and the HF fell from 0.66 to 0.31; docs/amplify.md).
  const bool input_gain = first_is_input && o.detail_gain < 0 && o.hf_from_input && o.bias_correction &&
                          d.spectral_scale > 0;
  if (fixed_rho && !input_gain && !relief) {
    rhos.assign(size_t(steps), std::clamp(o.detail_correlation, 0.f, 1.f));
    rhos.insert(rhos.end(), gains.begin(), gains.end());
    rhos.insert(rhos.end(), deltas.begin(), deltas.end());
    rhos.insert(rhos.end(), reliefs.begin(), reliefs.end());
    return rhos;
  }
  const int f = d.factor, halo = step_halo(d, o);
  // The window [x0, x1) x [y0, y1) of step k's input.
  std::function<Heightfield(int, int, int, int, int)> input = [&](int k, int x0, int y0, int x1, int y1) {
    if (k == 0) return read(x0, y0, x1 - x0, y1 - y0);
    int lw = width, lh = height;
    for (int j = 1; j < k; ++j) lw *= f, lh *= f;  // step k-1's input size
    const int a0 = std::max(0, x0 / f - halo), b0 = std::max(0, y0 / f - halo);
    const int a1 = std::min(lw, (x1 + f - 1) / f + halo), b1 = std::min(lh, (y1 + f - 1) / f + halo);
    const Heightfield prev = input(k - 1, a0, b0, a1, b1);
    const Heightfield up = amplify_step(prev, a0, b0, k - 1, rhos[size_t(k - 1)], deltas[size_t(k - 1)], d, o, index, {},
                                        gains[size_t(k - 1)], reliefs[size_t(k - 1)]);
    Heightfield w(x1 - x0, y1 - y0);
    for (int y = 0; y < w.height; ++y)
      for (int x = 0; x < w.width; ++x) w.at(x, y) = up.at(x0 - a0 * f + x, y0 - b0 * f + y);
    w.georef = up.georef;
    return w;
  };
  int w = width, h = height;
  for (int k = 0; k < steps; ++k, w *= f, h *= f) {
    const Rect r = rho_region(w, h);
    const int a0 = std::max(0, r.x0 - halo), b0 = std::max(0, r.y0 - halo);
    const int a1 = std::min(w, r.x1 + halo), b1 = std::min(h, r.y1 + halo);
    if (fixed_rho && k > 0 && !relief) {  // only the first step's gain needed measuring
      rhos.push_back(std::clamp(o.detail_correlation, 0.f, 1.f));
      continue;
    }
    const Heightfield win = input(k, a0, b0, a1, b1);
    require_finite(win, "amplify", "input");
    const StepEngine eng(win, a0, b0, k, d, o, index);
    if (relief && later(k))
      reliefs[size_t(k)] = eng.relief_scale((r.x0 - a0) * f, (r.y0 - b0) * f, (r.x1 - a0) * f, (r.y1 - b0) * f);
    if (fixed_rho && k > 0) {
      rhos.push_back(std::clamp(o.detail_correlation, 0.f, 1.f));
      continue;
    }
    const auto [rho, delta] =
        fixed_rho ? std::pair<float, float>{std::clamp(o.detail_correlation, 0.f, 1.f), 0.f}
                  : eng.measure_rho((r.x0 - a0) * f, (r.y0 - b0) * f, (r.x1 - a0) * f, (r.y1 - b0) * f);
    rhos.push_back(rho);
    deltas[size_t(k)] = delta;
    if (k == 0 && input_gain) {
      const Heightfield detail = amplify_step(win, a0, b0, k, rho, delta, d, o, index, {}, -1, 1, true);
      gains[0] = float(input_hf_gain(win, r.x0 - a0, r.y0 - b0, r.x1 - r.x0, r.y1 - r.y0, detail, d, o.base));
    }
  }
  rhos.insert(rhos.end(), gains.begin(), gains.end());
  rhos.insert(rhos.end(), deltas.begin(), deltas.end());
  rhos.insert(rhos.end(), reliefs.begin(), reliefs.end());
  return rhos;
}

std::unique_ptr<AtomIndex> make_index(const Dictionary& d, const AmplifyOptions& o) {
  const bool s1 = o.sparsity == 1 && o.search != "omp";
  if (!s1) return nullptr;
  if (o.search == "flann" || (o.search == "auto" && d.atoms() > 4096))
    return std::make_unique<AtomIndex>(d.low, o.trees, o.checks, o.seed, &d.low_norm, o.magnitude_weight);
  return nullptr;
}

// [a0, a1) along the exemplar's long axis (x when wide), [o0, o1) across: the calibration folds.
Heightfield fold_crop(const Heightfield& ex, bool wide, int a0, int a1, int o0, int o1) {
  const int w = wide ? a1 - a0 : o1 - o0, h = wide ? o1 - o0 : a1 - a0;
  const int x0 = wide ? a0 : o0, y0 = wide ? o0 : a0;
  Heightfield c(w, h);
  c.georef = ex.georef;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y) = ex.at(x0 + x, y0 + y);
  return c;
}

}  // namespace

double detail_relief_exponent(const Dictionary& d, const std::string& base) {
  const int n = d.atoms(), P = d.patch;
  if (d.low_norm.size() != size_t(n) || n < 16 || d.factor < 2) return -1;
  const MatrixF M = smooth_part_operator(P, d.factor, base);
  const int step = std::max(1, n / 4096);
  double sx = 0, sy = 0, sxx = 0, sxy = 0, cnt = 0;
  MatrixF detail(P, P);
  for (int j = 0; j < n; j += step) {
    const float norm = d.low_norm[size_t(j)];
    if (!(norm > 0)) continue;
    // The atom is its source patch over norm: |detail of the source| = |detail of the atom| norm.
    const Eigen::Map<const MatrixF> h(d.high.col(j).data(), P, P);
    detail.noalias() = h - M * h * M.transpose();
    const double dn = double(detail.norm()) * norm;
    if (!(dn > 0)) continue;
    const double x = std::log(double(norm)), y = std::log(dn);
    sx += x, sy += y, sxx += x * x, sxy += x * y, cnt += 1;
  }
  const double var = sxx - sx * sx / std::max(1.0, cnt);
  if (cnt < 16 || !(var > 0)) return -1;
  const double slope = (sxy - sx * sy / cnt) / var;
  return std::clamp(1.0 - slope, 0.0, 1.0);
}

int amplify_halo(const Dictionary& d, const AmplifyOptions& o) {
  const AmplifyOptions r = resolved(o, d);
  const int steps = steps_for(o.factor, d.factor), h = step_halo(d, r);
  int total = 0, scale = 1;
  for (int k = 0; k < steps; ++k, scale *= d.factor) total += (h + scale - 1) / scale;
  return total;
}

std::vector<float> amplify_correlations(const AmplifyWindowReader& read, int width, int height, const Dictionary& d,
                                        const AmplifyOptions& o) {
  check_options(o, d);
  if (d.factor < 2) fail("amplify", "the dictionary has factor {}: amplification needs a multi-resolution dictionary", d.factor);
  if (o.mode != "detail") return {};
  const int steps = steps_for(o.factor, d.factor);
  const AmplifyOptions r = resolved(o, d);
  const auto index = make_index(d, r);
  return step_correlations(read, width, height, steps, d, r, index.get());
}

Heightfield amplify_window(const Heightfield& low, int x0, int y0, const Dictionary& d, const AmplifyOptions& o,
                           const std::vector<float>& correlations, const Progress& progress) {
  require_finite(low, "amplify", "input");
  check_options(o, d);
  if (d.factor < 2) fail("amplify", "the dictionary has factor {}: amplification needs a multi-resolution dictionary", d.factor);
  const int steps = steps_for(o.factor, d.factor);
  if (o.mode == "faithful") {
    // The regression stored with the dictionary serves every step (self-similarity, as its atoms do).
    if (!d.has_regression())
      fail("amplify", "--mode faithful: the dictionary stores no faithful regression (written before format version 3, "
           "or its exemplar was too small: {}); learn it again with `terracl dictionary learn`, or give --exemplar",
           d.description);
    Heightfield cur = low;
    for (int k = 0; k < steps; ++k) {
      Heightfield next = apply_block_regression(cur, d.regression, o.threads);
      correct_block_means(next, cur, d.factor);  // exact already but for rounding
      cur = std::move(next);
      report_progress(progress, "amplify", double(k + 1) / steps, fmt::format("step {}/{}", k + 1, steps));
    }
    cur.metadata["amplify_mode"] = "faithful";
    cur.metadata["amplify_calibration"] = fmt::format("dictionary's regression radius {} from {} exemplar blocks",
                                                      d.regression.radius, d.regression.samples);
    cur.metadata["amplify_dictionary"] = d.description;
    return cur;
  }
  const AmplifyOptions r = resolved(o, d);
  const bool detail = r.blend == "detail";
  // rhos, gains, (since issue 16 session 8) anisotropies and (session 10) relief scales per step;
  // without the last ones, isotropic and unscaled.
  const size_t blocks = steps > 0 ? correlations.size() / size_t(steps) : 0;
  if (detail && (correlations.size() % size_t(steps) != 0 || blocks < 2 || blocks > 4))
    fail("amplify", "internal: {} detail correlations and gains for {} steps", correlations.size(), steps);
  const bool with_delta = detail && blocks >= 3, with_relief = detail && blocks >= 4;
  const auto index = make_index(d, r);
  Heightfield cur = low;
  std::string gains;
  for (int k = 0, scale = 1; k < steps; ++k, scale *= d.factor) {
    const float input_gain = detail ? correlations[size_t(steps + k)] : -1.f;
    cur = amplify_step(cur, x0 * scale, y0 * scale, k, detail ? correlations[size_t(k)] : 0.f,
                       with_delta ? correlations[size_t(2 * steps + k)] : 0.f, d, r, index.get(),
                       scaled_progress(progress, double(k) / steps, double(k + 1) / steps), input_gain,
                       with_relief ? correlations[size_t(3 * steps + k)] : 1.f);
    gains += (k ? "," : "") + cur.metadata["amplify_detail_gain"];
    if (input_gain > 0 && r.detail_gain < 0)
      cur.metadata["amplify_hf_calibration"] = fmt::format(
          "step {}: gain {:.3f} (dictionary's {:.3f}) from the held-out folds and this input's own spectrum",
          k + 1, input_gain, d.detail_gain);
  }
  if (detail && r.detail_gain < 0 && r.hf_from_input && r.bias_correction && !(d.spectral_scale > 0))
    cur.metadata["amplify_hf_calibration"] = fmt::format(
        "off: the dictionary carries no calibration for a per-input gain (a .tdic before format version 4, or an "
        "exemplar too small to calibrate); the dictionary's gain {:.3f}", d.detail_gain);
  cur.metadata["amplify_mode"] = "detail";
  cur.metadata["amplify_blend"] = r.blend;
  cur.metadata["amplify_base"] = r.base;
  cur.metadata["amplify_detail_gain"] = gains;
  cur.metadata["amplify_dictionary"] = d.description;
  return cur;
}

Heightfield amplify(const Heightfield& low, const Dictionary& d, const AmplifyOptions& o, const Progress& progress) {
  require_finite(low, "amplify", "input");
  check_options(o, d);
  std::vector<float> rhos;
  if (o.mode == "detail") {
    const AmplifyWindowReader read = [&](int x, int y, int w, int h) {
      Heightfield c(w, h);
      for (int v = 0; v < h; ++v) std::copy_n(&low.z[size_t(y + v) * low.width + x], w, &c.z[size_t(v) * w]);
      c.georef = low.georef;
      return c;
    };
    rhos = amplify_correlations(read, low.width, low.height, d, o);
  }
  return amplify_window(low, 0, 0, d, o, rhos, progress);
}

// The `terracl warp` command that resamples a raster of georef `g` to cells of cx x cy metres: --tr
// is in the raster's CRS units, so degrees scale by the metric cell size at its centre latitude.
static std::string warp_command(const std::string& file, const Georef& g, double cx, double cy) {
  const double sx = g.has_geotransform ? std::fabs(g.geotransform[1]) / g.cell_x : 1.0;
  const double sy = g.has_geotransform ? std::fabs(g.geotransform[5]) / g.cell_y : 1.0;
  return fmt::format("terracl warp {} -o {}_{:.0f}m.tif --tr {:.10g} {:.10g} --resampling average", file,
                     file == "<input>" ? "input" : "exemplar", cx, cx * sx, cy * sy);
}

// x16 as two x4 steps (docs/amplify.md, "per-scale calibration"): the first step's gain chosen end to
// end on the exemplar's held-out folds. Each fold's 16 x 16 block means are amplified by both steps
// (dictionaries learned on the other folds, at each step's cell size; the second step at gain `g2`)
// for a grid of first-step gains; the largest gain whose pooled final HF energy ratio stays at most
// `hf_target` and whose RMSE stays within kCascadeRmseBudget x bicubic's (x16) is taken, interpolated
// between grid points. `ex`: the exemplar at the cascade's output cell size. -1 when too small.
// The x16 target (1.3) less a margin for the transfer from the folds to other terrain: at 1.24 on the
// folds the Front Range's east half came out at 1.324 (docs/amplify.md).
constexpr double kCascadeRmseBudget = 1.2;
// The chosen gain and, at it (interpolated like the gain), the folds' pooled HF energy ratio, RMSE over
// bicubic's and mean-slope ratio (output over truth): what the calibration expects on the input.
struct CascadeGain {
  double gain = -1, hf = 0, rmse = 0, slope = 0;
};
CascadeGain cascade_first_gain(const Heightfield& ex, const LearnOptions& learn, const AmplifyOptions& o1,
                               const AmplifyOptions& o2, float g2, double hf_target) {
  const int f = learn.factor, F = f * f, P = learn.patch;
  const bool wide = ex.width >= ex.height;
  const int len = wide ? ex.width : ex.height, other = wide ? ex.height : ex.width;
  const int k = 2, fold = len / k;
  if (fold / f < 4 * P || other / f < 4 * P) return {};
  auto crop = [&](int a0, int a1, int o0, int o1) { return fold_crop(ex, wide, a0, a1, o0, o1); };
  LearnOptions lo = learn;
  lo.calibrate = false;
  lo.faithful_radius = 0;
  lo.max_patches = learn.max_patches / 2;
  const std::vector<double> grid = {1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75};
  std::vector<double> hf(grid.size(), 0), e2(grid.size(), 0), sl(grid.size(), 0);
  double ht = 0, eb2 = 0, slt = 0;
  for (int i = 0; i < k; ++i) {
    const int a0 = i * fold, a1 = i == k - 1 ? len : a0 + fold;
    std::vector<Heightfield> train2, train1;
    if (a0 >= P * f) train2.push_back(crop(0, a0, 0, other));
    if (len - a1 >= P * f) train2.push_back(crop(a1, len, 0, other));
    for (const auto& t : train2) train1.push_back(block_mean(t, f));
    const Heightfield b = crop(a0, a0 + (a1 - a0) / F * F, 0, other / F * F);
    const Heightfield low = block_mean(b, F);
    const Dictionary d1 = learn_dictionary(train1, lo), d2 = learn_dictionary(train2, lo);
    const std::vector<float> bic = bicubic_upsample(low, F).z;
    for (size_t j = 0; j < bic.size(); ++j) eb2 += double(bic[j] - b.z[j]) * (bic[j] - b.z[j]);
    ht += energy_above(b, F);
    slt += compute_stats(b).mean_slope_deg * double(b.size());
    AmplifyOptions a = o1, c = o2;
    a.factor = c.factor = f;
    c.detail_gain = g2;
    c.later_cascade_step = true;
    for (size_t q = 0; q < grid.size(); ++q) {
      a.detail_gain = float(grid[q]);
      const Heightfield out = amplify(amplify(low, d1, a), d2, c);
      hf[q] += energy_above(out, F);
      sl[q] += compute_stats(out).mean_slope_deg * double(out.size());
      for (size_t j = 0; j < out.z.size(); ++j) e2[q] += double(out.z[j] - b.z[j]) * (out.z[j] - b.z[j]);
    }
  }
  if (!(ht > 0) || !(eb2 > 0) || !(slt > 0)) return {};
  // The excess over each bound per grid gain (<= 0: within); the gain where the first one reaches 0.
  auto excess = [&](size_t q) {
    return std::max(hf[q] / ht - hf_target, std::sqrt(e2[q] / eb2) - kCascadeRmseBudget);
  };
  // Grid position q + t (t in [0, 1]) of the chosen gain, and the folds' figures there.
  size_t q0 = 0;
  double t = 0;
  if (excess(0) <= 0) {
    q0 = grid.size() - 1;
    for (size_t q = 1; q < grid.size(); ++q) {
      const double x0 = excess(q - 1), x1 = excess(q);
      if (x1 > 0) {
        q0 = q - 1, t = (-x0) / std::max(1e-12, x1 - x0);
        break;
      }
    }
  }
  const size_t q1 = std::min(q0 + 1, grid.size() - 1);
  auto at = [&](const std::vector<double>& v) { return v[q0] + t * (v[q1] - v[q0]); };
  CascadeGain r;
  r.gain = at(grid);
  r.hf = at(hf) / ht;
  r.rmse = std::sqrt(at(e2) / eb2);
  r.slope = at(sl) / slt;
  return r;
}

Heightfield amplify_from_exemplars(const Heightfield& low, const std::vector<Heightfield>& exemplars,
                                   const LearnOptions& learn, const AmplifyOptions& o, const Progress& progress) {
  require_finite(low, "amplify", "input");
  if (exemplars.empty()) fail("amplify", "no exemplar given");
  if (o.mode != "detail" && o.mode != "faithful") fail("amplify", "mode '{}' is not one of detail|faithful", o.mode);
  const int steps = steps_for(o.factor, learn.factor);
  const Georef& e = exemplars[0].georef;
  Heightfield cur = low;
  std::unique_ptr<Dictionary> dict, next_dict;
  std::unique_ptr<BlockRegression> reg;
  std::vector<std::string> gains, notes, hf_notes;
  double cascade_gain = -1;
  CascadeGain cascade;
  LearnOptions lo = learn;  // calibrate the gain for the search used here
  if (o.neighbours > 0) lo.calibration_neighbours = o.neighbours;
  lo.calibration_candidates = o.candidates;
  if (o.magnitude_weight >= 0) lo.calibration_magnitude_weight = o.magnitude_weight;
  if (o.blend != "auto") lo.calibration_blend = o.blend;
  if (o.base != "auto") lo.calibration_base = o.base;
  lo.calibration_anisotropy = o.detail_anisotropy;
  lo.faithful_radius = 0;  // detail mode here; faithful mode learns its own regression below
  for (int k = 0; k < steps; ++k) {
    const double tx = cur.georef.cell_x / learn.factor, ty = cur.georef.cell_y / learn.factor;
    const double rx = tx / e.cell_x, ry = ty / e.cell_y;
    const Progress pk = scaled_progress(progress, double(k) / steps, double(k + 1) / steps);
    if (rx < 0.95 || ry < 0.95) {
      // The exemplar has no detail this fine: reuse the finest dictionary (self-similarity).
      if (!dict && !reg)
        fail("amplify", "mismatched cell sizes: the exemplar's {:.3f} x {:.3f} m cells are coarser than the output's "
             "{:.3f} x {:.3f} m; coarsen the input to {:.3f} x {:.3f} m cells first: {}",
             e.cell_x, e.cell_y, tx, ty, e.cell_x * learn.factor, e.cell_y * learn.factor,
             warp_command("<input>", cur.georef, e.cell_x * learn.factor, e.cell_y * learn.factor));
    } else {
      const int r = int(std::lround(rx));
      if (std::fabs(rx - r) > 0.05 * rx || std::fabs(ry - r) > 0.05 * ry)
        fail("amplify", "mismatched cell sizes: output cells {:.3f} x {:.3f} m are not a whole multiple of the exemplar's "
             "{:.3f} x {:.3f} m; resample the exemplar to the output's cells first: {}", tx, ty, e.cell_x, e.cell_y,
             warp_command("<exemplar>", e, tx, ty));
      std::vector<Heightfield> ex;
      for (const auto& h : exemplars) ex.push_back(r > 1 ? block_mean(h, r) : h);
      if (o.mode == "faithful") {
        reg = std::make_unique<BlockRegression>(learn_block_regression(ex, learn.factor, o.faithful_radius));
        notes.push_back(fmt::format("step {}: regression radius {} from {} exemplar blocks", k + 1, reg->radius,
                                    reg->samples));
      } else if (next_dict) {
        dict = std::move(next_dict);
        notes.push_back(fmt::format("step {}: {}", k + 1, dict->description));
      } else {
        dict = std::make_unique<Dictionary>(learn_dictionary(ex, lo, scaled_progress(pk, 0, 0.5)));
        notes.push_back(fmt::format("step {}: {}", k + 1, dict->description));
        // x16: the first step's gain from the whole cascade on the exemplar's folds (cascade_first_gain),
        // with the second step's dictionary learned now (and used at the second step).
        const double r2x = rx / learn.factor, r2y = ry / learn.factor;
        const int r2 = int(std::lround(r2x));
        // Only where the per-input gain cannot apply (an input under kMinSpectralInput cells: the
        // spectral fit needs more); on larger inputs the first step keeps it (not measured at x16).
        const bool small = cur.width < kMinSpectralInput || cur.height < kMinSpectralInput;
        if (k == 0 && steps == 2 && small && o.detail_gain < 0 && o.cascade_calibration && r2 >= 1 &&
            std::fabs(r2x - r2) <= 0.05 * r2x && std::fabs(r2y - r2) <= 0.05 * r2y) {
          std::vector<Heightfield> ex2;
          for (const auto& h : exemplars) ex2.push_back(r2 > 1 ? block_mean(h, r2) : h);
          next_dict = std::make_unique<Dictionary>(learn_dictionary(ex2, lo, scaled_progress(pk, 0.25, 0.5)));
          check_options(o, *next_dict);
          cascade = cascade_first_gain(ex2[0], lo, resolved(o, *dict), resolved(o, *next_dict),
                                       next_dict->detail_gain, lo.calibration_hf_target);
          cascade_gain = cascade.gain;
        }
      }
    }
    if (reg) {
      Heightfield next = apply_block_regression(cur, *reg, o.threads);
      correct_block_means(next, cur, learn.factor);  // exact already but for rounding
      cur = std::move(next);
      report_progress(pk, "amplify", 1.0, fmt::format("step {}/{}", k + 1, steps));
      continue;
    }
    check_options(o, *dict);
    const AmplifyOptions r = resolved(o, *dict);
    const auto index = make_index(*dict, r);
    const Heightfield& in = cur;
    const AmplifyWindowReader read = [&in](int x, int y, int w, int h) {
      Heightfield c(w, h);
      for (int v = 0; v < h; ++v) std::copy_n(&in.z[size_t(y + v) * in.width + x], w, &c.z[size_t(v) * w]);
      c.georef = in.georef;
      return c;
    };
    AmplifyOptions rk = r;
    if (k == 0 && cascade_gain > 0) rk.detail_gain = float(cascade_gain);
    rk.later_cascade_step = k > 0;  // steps run one call each here
    const auto rho = step_correlations(read, cur.width, cur.height, 1, *dict, rk, index.get(), k == 0);
    const float input_gain = rho.size() >= 2 ? rho[1] : -1.f;  // one step: rho, gain, delta, relief scale
    cur = amplify_step(cur, 0, 0, k, rho.empty() ? 0.f : rho[0], rho.size() >= 3 ? rho[2] : 0.f, *dict, rk, index.get(), scaled_progress(pk, 0.5, 1),
                       input_gain, rho.size() >= 4 ? rho[3] : 1.f);
    gains.push_back(cur.metadata["amplify_detail_gain"]);
    if (k == 0 && cascade_gain > 0)
      hf_notes.push_back(fmt::format("step 1: gain {:.3f} (dictionary's {:.3f}) from both steps on the exemplar's held-out "
                                     "folds (x16 HF target {:.2f}, RMSE budget {:.2f} x bicubic; there: HF {:.3f}, RMSE "
                                     "{:.3f} x bicubic, slope {:.3f})", cascade_gain, dict->detail_gain,
                                     lo.calibration_hf_target, kCascadeRmseBudget, cascade.hf, cascade.rmse, cascade.slope));
    if (input_gain > 0 && r.detail_gain < 0)
      hf_notes.push_back(fmt::format("step {}: gain {:.3f} (dictionary's {:.3f}) from the held-out folds and this "
                                     "input's own spectrum", k + 1, input_gain, dict->detail_gain));
    cur.metadata["amplify_blend"] = r.blend;
    cur.metadata["amplify_base"] = r.base;
  }
  auto join = [](const std::vector<std::string>& v, const char* sep) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
    return s;
  };
  cur.metadata["amplify_mode"] = o.mode;
  if (!gains.empty()) cur.metadata["amplify_detail_gain"] = join(gains, ",");
  cur.metadata["amplify_calibration"] = join(notes, " | ");
  if (!hf_notes.empty()) cur.metadata["amplify_hf_calibration"] = join(hf_notes, " | ");
  return cur;
}

// Gain range, and the RMSE the calibration may spend (relative to bicubic's on the held-out folds);
// 1.14 leaves a margin under the evaluation target (1.2) for the exemplar-to-input transfer.
constexpr double kMinGain = 0.25, kMaxGain = 4.0, kRmseBudget = 1.14;

std::string GainCalibration::summary() const {
  if (!calibrated) return fmt::format("gain {:.3f} (exemplar too small to calibrate)", gain);
  return fmt::format("gain {:.3f}: held-out HF ratio {:.3f}, RMSE {:.3f} x bicubic (HF-matching gain {:.3f}, "
                     "RMSE-budget gain {:.3f})", gain, hf_ratio, rmse_ratio, hf_gain, rmse_gain);
}

GainCalibration calibrate_detail(const Heightfield& ex, const LearnOptions& o) {
  const int f = o.factor;
  GainCalibration cal;
  // Folds are strips across the longer axis; each must hold several patches.
  const bool wide = ex.width >= ex.height;
  const int len = wide ? ex.width : ex.height, other = wide ? ex.height : ex.width;
  int k = std::max(2, o.calibration_folds);
  while (k > 2 && len / k < 4 * o.patch) --k;
  if (len / k < 4 * o.patch || other < 4 * o.patch) return cal;
  auto crop = [&](int a0, int a1, int o0, int o1) { return fold_crop(ex, wide, a0, a1, o0, o1); };
  AmplifyOptions ao;
  ao.factor = f;
  ao.spacing = o.calibration_spacing;
  ao.sparsity = o.sparsity;
  ao.detail_gain = 1;
  ao.bias_correction = false;
  ao.threads = o.threads;
  ao.seed = o.seed;
  ao.neighbours = o.calibration_neighbours;
  ao.candidates = o.calibration_candidates;
  ao.magnitude_weight = o.calibration_magnitude_weight;
  ao.blend = o.calibration_blend;
  ao.base = o.calibration_base;
  ao.detail_anisotropy = o.calibration_anisotropy;
  // Sums over every held-out fold (pooled cross-validation): the HF energy terms hb, hbd, hd, ht and
  // the RMSE terms e2, ed, d2, r2 defined below.
  double hb = 0, hbd = 0, hd = 0, ht = 0, e2 = 0, ed = 0, d2 = 0, r2 = 0, sp = 0, spt = 0;
  const int fold = len / k;
  for (int i = 0; i < k; ++i) {
    const int a0 = i * fold, a1 = i == k - 1 ? len : a0 + fold;
    std::vector<Heightfield> train;
    if (a0 >= o.patch) train.push_back(crop(0, a0, 0, other));
    if (len - a1 >= o.patch) train.push_back(crop(a1, len, 0, other));
    const Heightfield b = crop(a0, a0 + (a1 - a0) / f * f, 0, other / f * f);
    LearnOptions lo = o;
    lo.faithful_radius = 0;  // the folds' dictionaries serve detail mode only
    const Dictionary d = learn_dictionary(train, lo);
    const Heightfield low = block_mean(b, f);
    const Heightfield out = amplify(low, d, ao);
    // The output is bicubic + g detail followed by the bias correction C, which is affine
    // (back-projection and block shifts), so C(bic + g det) = cb + g cd with cb = C(bic) and
    // cd = C(out) - cb: two corrections give every candidate gain exactly, as the default output.
    const std::vector<float> bic = bicubic_upsample(low, f).z;  // the RMSE budget's reference
    Heightfield cb = upsample(low, f, o.calibration_base);
    correct_block_means(cb, low, f, 4, o.calibration_base);
    Heightfield cd = out;
    correct_block_means(cd, low, f, 4, o.calibration_base);
    for (size_t j = 0; j < cd.z.size(); ++j) cd.z[j] -= cb.z[j];
    // HF energy (the evaluation's, linear in the heightfield): |Sb + g Sd|^2 against |St|^2.
    const auto sb = spectrum_above(cb, f), sd = spectrum_above(cd, f), st = spectrum_above(b, f);
    double htf = 0;
    for (size_t j = 0; j < sb.size(); ++j) {
      hb += std::norm(sb[j]), hbd += std::real(sb[j] * std::conj(sd[j])), hd += std::norm(sd[j]);
      htf += std::norm(st[j]);
    }
    ht += htf;
    // How the input-spectrum extrapolation relates to the held-out truth on this exemplar.
    const double pred = predicted_energy_above(low, f);
    if (pred > 0) sp += pred, spt += htf;
    for (size_t j = 0; j < cd.z.size(); ++j) {
      const double e0 = double(cb.z[j]) - b.z[j], rb = double(bic[j]) - b.z[j];
      e2 += e0 * e0, ed += e0 * cd.z[j], d2 += double(cd.z[j]) * cd.z[j], r2 += rb * rb;
    }
  }
  if (!(hd > 0) || !(d2 > 0) || !(r2 > 0)) return cal;
  cal.calibrated = true;
  // As much HF energy as the held-out truth (times the target): hd g^2 + 2 hbd g + hb = t ht (the
  // larger root).
  const double disc = hbd * hbd - hd * (hb - o.calibration_hf_target * ht);
  cal.hf_gain = disc > 0 ? (-hbd + std::sqrt(disc)) / hd : 1.0;
  // The largest g with |e0 + g cd|^2 <= (budget * rmse_bic)^2, e0 = cb - truth.
  const double lim = kRmseBudget * kRmseBudget * r2;
  const double q = ed * ed - d2 * (e2 - lim);
  cal.rmse_gain = q > 0 ? (-ed + std::sqrt(q)) / d2 : 0.0;
  // Real relief, not more; less only where the RMSE budget says so.
  const double g = std::clamp(std::min(cal.hf_gain, cal.rmse_gain), kMinGain, kMaxGain);
  cal.gain = g;
  cal.hf_ratio = (hb + 2 * g * hbd + g * g * hd) / std::max(1e-30, ht);
  cal.rmse_ratio = std::sqrt(std::max(0.0, e2 + 2 * g * ed + g * g * d2) / r2);
  if (sp > 0 && spt > 0) cal.spectral_scale = spt / sp;
  return cal;
}

double calibrate_detail_gain(const Heightfield& ex, const LearnOptions& o) { return calibrate_detail(ex, o).gain; }

void smooth_tent(Heightfield& m, int r) {
  for (int pass = 0; pass < 2 && r > 0; ++pass) {
    Heightfield t = m;
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x) {
        double s = 0;
        for (int u = -r; u <= r; ++u) s += m.at(clampi(x + u, m.width), y);
        t.at(x, y) = float(s / (2 * r + 1));
      }
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x) {
        double s = 0;
        for (int v = -r; v <= r; ++v) s += t.at(x, clampi(y + v, m.height));
        m.at(x, y) = float(s / (2 * r + 1));
      }
  }
}

Heightfield synthesize_from_sketch(const Heightfield& sketch, const Dictionary& d, double smooth_cells,
                                   const AmplifyOptions& o, const Progress& progress) {
  require_finite(sketch, "sketch", "sketch");
  // Painted sketches are piecewise flat with hard edges; a tent filter turns the edges into slopes
  // the low-resolution atoms can match (flat areas match no atom and stay flat).
  Heightfield s = sketch;
  smooth_tent(s, std::max(0, int(std::lround(smooth_cells / 2))));
  return amplify(s, d, o, progress);
}

Heightfield amplify_styles(const Heightfield& low, const std::vector<const Dictionary*>& dicts, const Heightfield& mask,
                           double blend_cells, const AmplifyOptions& o, const Progress& progress) {
  if (dicts.size() != 2) fail("amplify", "style blending takes exactly two dictionaries (got {})", dicts.size());
  if (mask.width != low.width || mask.height != low.height)
    fail("amplify", "style mask is {}x{} but the input is {}x{}", mask.width, mask.height, low.width, low.height);
  require_finite(mask, "amplify", "style mask");
  const Heightfield a = amplify(low, *dicts[0], o, scaled_progress(progress, 0, 0.45));
  const Heightfield b = amplify(low, *dicts[1], o, scaled_progress(progress, 0.45, 0.9));
  // Smooth the mask (a tent) so styles blend across its edge.
  Heightfield m = mask;
  for (auto& v : m.z) v = std::clamp(v, 0.f, 1.f);
  smooth_tent(m, std::max(0, int(std::lround(blend_cells / 2))));
  const Heightfield mh = bicubic_upsample(m, o.factor);
  Heightfield out = a;
  for (size_t i = 0; i < out.z.size(); ++i) {
    const float t = std::clamp(mh.z[i], 0.f, 1.f);
    out.z[i] = (1 - t) * a.z[i] + t * b.z[i];
  }
  if (o.bias_correction) correct_block_means(out, low, o.factor);
  report_progress(progress, "amplify", 1.0, "styles blended");
  return out;
}

}  // namespace terracl
