// Amplification by a multi-resolution dictionary (sparse terrain paper, section 5.3): each output
// patch's low-resolution footprint is decomposed over L, the same coefficients applied to H, and the
// patches blended with the disc weights; then the block means are corrected to match the input.
// The output is produced tile by tile (only the tile's patches, codes and blend buffers are held).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
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
  return o;
}

constexpr int kMinSpectralInput = 64;

// Per-input HF calibration (docs/amplify.md, "per-input HF"): the gain whose output HF energy, on
// the central (up to) 256 x 256 input cells, is the geometric mean of two estimates of the truth's:
// the held-out folds' (the output's HF at the dictionary's HF-matching gain over its HF target) and
// the input's own spectrum extrapolated (predicted_energy_above, scaled by the ratio the folds
// measured). Their errors are independent (the folds know the dictionary, the spectrum knows this
// terrain). Capped by the folds' RMSE-budget gain. `detail` is the blended detail before the gain;
// -1 when the dictionary carries no in-memory calibration (loaded files) or the input is too small.
double input_hf_gain(const Heightfield& low, const Heightfield& detail, const Dictionary& d, const std::string& base,
                     Metadata* metadata) {
  if (!(d.spectral_scale > 0) || !(d.hf_gain > 0) || !(d.hf_target > 0) || !(d.rmse_gain > 0)) return -1;
  const int f = d.factor;
  const int cw = std::min(low.width, 256), ch = std::min(low.height, 256);
  // Smaller inputs leave too few bins in the octave for the fit (a 23 x 47 input, the Front Range at
  // x16, gave 0.06 x the held-out estimate).
  if (cw < kMinSpectralInput || ch < kMinSpectralInput) return -1;
  const int lx0 = (low.width - cw) / 2, ly0 = (low.height - ch) / 2;
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
  g = std::clamp(g, 0.25, std::min(4.0, d.rmse_gain));
  if (metadata)
    (*metadata)["amplify_hf_calibration"] = fmt::format(
        "gain {:.3f} (dictionary's {:.3f}): HF energy target {:.4g} = geometric mean of held-out {:.4g} and "
        "input spectrum {:.4g} (central {}x{} input cells)", g, d.detail_gain, target, held_out, spectral, cw, ch);
  return g;
}

// One x f step.
Heightfield amplify_step(const Heightfield& low, const Dictionary& d, const AmplifyOptions& o, const AtomIndex* index,
                         const Progress& progress, bool first_step) {
  const int f = d.factor, P = d.patch, p = d.low_patch(), S = o.spacing, Q = P - S;
  const int W = low.width * f, H = low.height * f;
  Heightfield out(W, H);
  out.georef = low.georef.resampled(f);
  out.metadata = low.metadata;
  const auto weights = patch_weights(P);
  const auto lmask = patch_mask(p);
  double lmsum = 0;
  for (float m : lmask) lmsum += m;
  const bool use_omp = o.sparsity > 1 || o.search == "omp";
  const bool detail_blend = o.blend == "detail";
  // The smooth part M X M^T with M = U B (B: P/f x P block means, U = f M B^T: P x P/f bicubic),
  // computed as U (B X B^T) U^T: ~2.5k multiply-adds per patch instead of 8k for two P^3 products.
  const int pm_ = P / f;
  MatrixF bmat = MatrixF::Zero(pm_, P);
  for (int x = 0; x < pm_; ++x)
    for (int u = 0; u < f; ++u) bmat(x, x * f + u) = 1.f / f;
  const MatrixF umat = float(f) * smooth_part_operator(P, f, o.base) * bmat.transpose();
  // The magnitude term compares relief at the dictionary's cell size (self-similar scaling when a
  // dictionary serves a coarser step).
  const float qscale = d.cell_x > 0 && out.georef.cell_x > 0 ? float(d.cell_x / out.georef.cell_x) : 1.f;
  const int tile_unit = std::lcm(S, 64), tile = std::max(tile_unit, o.tile / tile_unit * tile_unit);
  const int tx = (W + tile - 1) / tile, ty = (H + tile - 1) / tile;
  // Patch k covers output cells [k S - Q, k S - Q + P); its low-resolution footprint starts at (k S - Q) / f.
  auto first = [&](int a) { int k = 0; while (k * S - Q + P <= a) ++k; return k; };
  auto last = [&](int b) { int k = 0; while (k * S - Q < b) ++k; return k; };  // exclusive
  const int phases = (P + S - 1) / S;  // patch rows this far apart never overlap

  // Detail blend: a first pass measures, for candidate correlations rho, the squared curvature of the
  // blended detail per phase of the patch grid (the weights repeat with the spacing); the second
  // blends with the rho that makes it the same at every phase (the evaluation's periodic trace). The
  // sums are per cell, so rho does not depend on the tiling.
  float rho = std::clamp(o.detail_correlation, 0.f, 1.f);
  const bool measure = detail_blend && o.detail_correlation < 0;
  // Band-limited base: rho flattens the curvature of base + 2 detail per phase (2: a typical
  // calibrated gain, fixed so that the output stays affine in the gain, as the calibration needs). The
  // bicubic base's knots have a phase pattern of their own that the detail partly offsets; there
  // rho flattens the detail alone (measuring the output as well moved no figure: docs/amplify.md).
  const bool measure_output = measure && o.base == "bandlimited";
  constexpr int kRhos = 11;
  constexpr double kRhoGain = 2.0;
  std::vector<double> phase_k2(size_t(kRhos) * S * S, 0.0), phase_n(size_t(S) * S, 0.0);
  // The first pass's codes and patch means, per tile, reused by the second (no second atom search).
  struct TileCodes {
    SparseCodes codes;
    std::vector<float> z;
  };
  std::vector<TileCodes> cache(measure ? size_t(tx) * ty : 0);
  for (int pass = measure ? 0 : 1; pass < 2; ++pass) {
  if (pass == 1 && measure) {
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
    const int t = int(std::min_element(cv.begin(), cv.end()) - cv.begin());
    double r = double(t) / (kRhos - 1);
    if (t > 0 && t < kRhos - 1) {  // parabola through the minimum and its neighbours
      const double a = cv[size_t(t - 1)], b = cv[size_t(t)], c = cv[size_t(t + 1)], d = a - 2 * b + c;
      if (d > 0) r += std::clamp(0.5 * (a - c) / d, -0.5, 0.5) / (kRhos - 1);
    }
    rho = float(r);
  }
  for (int j = 0; j < ty; ++j)
    for (int i = 0; i < tx; ++i) {
      const int X0 = i * tile, X1 = std::min(W, X0 + tile), Y0 = j * tile, Y1 = std::min(H, Y0 + tile);
      const int kx0 = first(X0), kx1 = last(X1), ky0 = first(Y0), ky1 = last(Y1);
      const int nx = kx1 - kx0, ny = ky1 - ky0;
      const size_t m = size_t(nx) * ny;
      std::vector<float> z;
      SparseCodes codes;
      const size_t tile_id = size_t(j) * tx + i;
      if (pass == 1 && measure) {
        codes = std::move(cache[tile_id].codes);
        z = std::move(cache[tile_id].z);
      } else {
        z.resize(m);
        MatrixF q(p * p, Eigen::Index(m));
        parallel_for(m, o.threads, [&](size_t b, size_t e) {
          for (size_t c = b; c < e; ++c) {
            const int lx = ((kx0 + int(c % nx)) * S - Q) / f, ly = ((ky0 + int(c / nx)) * S - Q) / f;
            double s = 0;
            for (int v = 0; v < p; ++v)
              for (int u = 0; u < p; ++u)
                s += lmask[v * p + u] * low.at(clampi(lx + u, low.width), clampi(ly + v, low.height));
            const float mean = float(s / lmsum);
            for (int v = 0; v < p; ++v)
              for (int u = 0; u < p; ++u)
                q(v * p + u, Eigen::Index(c)) =
                    lmask[v * p + u] * (low.at(clampi(lx + u, low.width), clampi(ly + v, low.height)) - mean);
            z[c] = mean;
          }
        });
        if (use_omp) {
          codes = batch_omp(d.low, q, o.sparsity, o.threads);
        } else {
          // k nearest atoms averaged: their shared detail adds up, the rest partly cancels. With a
          // larger candidate pool, each patch draws its k from the pool by a hash of its position, so
          // that equal footprints (straight painted edges) do not repeat the same detail.
          const int k = std::max(1, o.neighbours), pool = std::max(k, o.candidates);
          AtomMatch a = index ? index->search(q, o.threads, pool, qscale)
                              : exact_atom_search(d.low, q, o.threads, pool, &d.low_norm, o.magnitude_weight, qscale);
          AtomMatch chosen;
          chosen.index.assign(m * size_t(k), -1);
          chosen.coef.assign(m * size_t(k), 0.f);
          for (size_t c = 0; c < m; ++c) {
            int32_t* idx = &a.index[c * pool];
            float* coef = &a.coef[c * pool];
            int found = 0;
            while (found < pool && idx[found] >= 0) ++found;
            if (found > k) {
              uint64_t h = position_hash(o.seed, W, kx0 + int(c % nx), ky0 + int(c / nx));
              for (int t = 0; t < k; ++t) {  // partial Fisher-Yates
                h = position_hash(h, t, 0, 0);
                const int r = t + int(h % uint64_t(found - t));
                std::swap(idx[t], idx[r]);
                std::swap(coef[t], coef[r]);
              }
              found = k;
            }
            for (int t = 0; t < found; ++t) {
              chosen.index[c * k + t] = idx[t];
              chosen.coef[c * k + t] = coef[t] / float(found);
            }
          }
          a = std::move(chosen);
          codes.sparsity = k;
          codes.index = std::move(a.index);
          codes.coef = std::move(a.coef);
        }
      }
      const int s = codes.sparsity;
      const int tw = X1 - X0, th = Y1 - Y0;
      std::vector<float> num(size_t(tw) * th, 0.f), den(num.size(), 0.f), den1(detail_blend ? num.size() : 0, 0.f);

      for (int ph = 0; ph < phases; ++ph) {
        std::vector<int> rows;
        for (int r = ph; r < ny; r += phases) rows.push_back(r);
        parallel_for(rows.size(), o.threads, [&](size_t b, size_t e) {
          VectorF patch(P * P);
          MatrixF detail(P, P), bx(pm_, P), cm(pm_, pm_), ucm(P, pm_);
          for (size_t ri = b; ri < e; ++ri) {
            const int r = rows[ri];
            for (int cx = 0; cx < nx; ++cx) {
              const size_t c = size_t(r) * nx + cx;
              const int px = (kx0 + cx) * S - Q - X0, py = (ky0 + r) * S - Q - Y0;
              // The patch (its atoms combined once), then its weighted blend.
              patch.setConstant(z[c]);
              for (int t = 0; t < s; ++t) {
                const int a = codes.index[c * s + t];
                if (a >= 0) patch += codes.coef[c * s + t] * d.high.col(a);
              }
              if (detail_blend) {
                // Only the patch's detail (what its block means do not determine) is blended; the
                // bicubic of the input supplies the rest.
                Eigen::Map<MatrixF> pm(patch.data(), P, P);
                bx.noalias() = bmat * pm;  // preallocated: no allocation per patch
                cm.noalias() = bx * bmat.transpose();
                ucm.noalias() = umat * cm;
                detail = pm;
                detail.noalias() -= ucm * umat.transpose();
              }
              const float* src = detail_blend ? detail.data() : patch.data();
              for (int v = std::max(0, -py); v < P && py + v < th; ++v)
                for (int u = std::max(0, -px); u < P && px + u < tw; ++u) {
                  const int k = v * P + u;
                  const float w = weights[k];
                  if (w == 0.f) continue;
                  const size_t o2 = size_t(py + v) * tw + px + u;
                  num[o2] += w * src[k];
                  den[o2] += detail_blend ? w * w : w;
                  if (detail_blend) den1[o2] += w;
                }
            }
          }
        });
      }
      if (pass == 0) {
        // One band of S rows in four (by the global row, every phase of the grid) is enough. Rows in
        // parallel, each into its own sums, added in row order: rho does not depend on the threads.
        std::vector<double> row_k2(size_t(th) * kRhos * S, 0.0), row_n(size_t(th) * S, 0.0);
        // With the band-limited base, rho flattens the output's curvature (base + gain detail) per
        // phase, not the detail's alone: the base has no phase pattern of its own to offset.
        parallel_for(size_t(th), o.threads, [&](size_t b, size_t e) {
          std::vector<double> bl(size_t(3) * kRhos * tw);  // rows y-1, y, y+1 blended for every rho
          std::vector<float> base_rows(measure_output ? size_t(3) * tw : 0);  // the base there
          for (size_t yy = b; yy < e; ++yy) {
            const int y = int(yy);
            if (y < 1 || y + 1 >= th || ((Y0 + y) / S) % 4 != 0) continue;
            const int gy = (Y0 + y) % 64;
            if (gy == 0 || gy == 63) continue;
            if (measure_output) upsample_window(low, f, o.base, X0, Y0 + y - 1, tw, 3, base_rows.data());
            for (int dy = 0; dy < 3; ++dy)
              for (int x = 0; x < tw; ++x) {
                const size_t c = size_t(y - 1 + dy) * tw + x;
                for (int t = 0; t < kRhos; ++t) {
                  const float r = float(t) / (kRhos - 1);
                  const double v = double(num[c]) / std::sqrt((1 - r) * den[c] + r * den1[c] * den1[c]);
                  bl[(size_t(dy) * kRhos + t) * tw + x] = measure_output ? base_rows[size_t(dy) * tw + x] + kRhoGain * v : v;
                }
              }
            double* k2 = &row_k2[size_t(y) * kRhos * S];
            double* n = &row_n[size_t(y) * S];
            for (int x = 1; x + 1 < tw; ++x) {
              // Cells next to a multiple of 64 are left out: tiles are multiples of 64 (below), so the
              // cells measured, and rho, are the same for every tile size.
              const int gx = (X0 + x) % 64;
              if (gx == 0 || gx == 63) continue;
              const int ph = (X0 + x) % S;
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
          const size_t py = size_t((Y0 + y) % S) * S;
          for (int ph = 0; ph < S; ++ph) {
            phase_n[py + ph] += row_n[size_t(y) * S + ph];
            for (int t = 0; t < kRhos; ++t)
              phase_k2[size_t(t) * phase_n.size() + py + ph] += row_k2[(size_t(y) * kRhos + t) * S + ph];
          }
        }
        if (measure) {
          cache[tile_id].codes = std::move(codes);
          cache[tile_id].z = std::move(z);
        }
        continue;
      }
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const float dn = den[size_t(y) * tw + x];
          if (!(dn > 0)) fail("amplify", "spacing {} leaves cells uncovered by {}-cell patches", S, P);
          // Detail blend: details with pairwise correlation rho have var(sum w_i d_i) = sigma^2 ((1 - rho)
          // sum w_i^2 + rho (sum w_i)^2); dividing by its square root keeps the detail's variance the
          // same wherever the patches overlap (a partition of unity, sum w_i d_i / sum w_i, right for
          // rho = 1 only, halves the variance of uncorrelated details between two patch centres and
          // quarters it between four: a ripple with the spacing).
          const size_t c = size_t(y) * tw + x;
          const float norm = detail_blend ? std::sqrt((1 - rho) * dn + rho * den1[c] * den1[c]) : dn;
          out.at(X0 + x, Y0 + y) = num[c] / norm;
        }
      report_progress(progress, "amplify", double(j * tx + i + 1) / (tx * ty), fmt::format("tile {}/{}", j * tx + i + 1, tx * ty));
    }
  }
  if (detail_blend) out.metadata["amplify_detail_correlation"] = fmt::format("{:.3f}", rho);
  float gain = o.detail_gain < 0 ? d.detail_gain : o.detail_gain;
  // Only the first step of a cascade sees measured terrain: later steps' inputs carry the previous
  // step's synthesized spectrum (at x16 on the Front Range its RMSE-capped gain made the second
  // step's estimate 0.55 x the held-out one and the HF fell from 0.66 to 0.31; docs/amplify.md).
  if (first_step && detail_blend && o.detail_gain < 0 && o.hf_from_input && o.bias_correction) {
    const double g = input_hf_gain(low, out, d, o.base, &out.metadata);
    if (g > 0) gain = float(g);
  }
  out.metadata["amplify_detail_gain"] = fmt::format("{:.3f}", gain);
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

std::unique_ptr<AtomIndex> make_index(const Dictionary& d, const AmplifyOptions& o) {
  const bool s1 = o.sparsity == 1 && o.search != "omp";
  if (!s1) return nullptr;
  if (o.search == "flann" || (o.search == "auto" && d.atoms() > 4096))
    return std::make_unique<AtomIndex>(d.low, o.trees, o.checks, o.seed, &d.low_norm, o.magnitude_weight);
  return nullptr;
}

}  // namespace

Heightfield amplify(const Heightfield& low, const Dictionary& d, const AmplifyOptions& o, const Progress& progress) {
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
  const auto index = make_index(d, r);
  Heightfield cur = low;
  std::string gains;
  for (int k = 0; k < steps; ++k) {
    cur = amplify_step(cur, d, r, index.get(), scaled_progress(progress, double(k) / steps, double(k + 1) / steps), k == 0);
    gains += (k ? "," : "") + cur.metadata["amplify_detail_gain"];
  }
  cur.metadata["amplify_mode"] = "detail";
  cur.metadata["amplify_blend"] = r.blend;
  cur.metadata["amplify_base"] = r.base;
  cur.metadata["amplify_detail_gain"] = gains;
  cur.metadata["amplify_dictionary"] = d.description;
  return cur;
}

// The `terracl warp` command that resamples a raster of georef `g` to cells of cx x cy metres: --tr
// is in the raster's CRS units, so degrees scale by the metric cell size at its centre latitude.
static std::string warp_command(const std::string& file, const Georef& g, double cx, double cy) {
  const double sx = g.has_geotransform ? std::fabs(g.geotransform[1]) / g.cell_x : 1.0;
  const double sy = g.has_geotransform ? std::fabs(g.geotransform[5]) / g.cell_y : 1.0;
  return fmt::format("terracl warp {} -o {}_{:.0f}m.tif --tr {:.10g} {:.10g} --resampling average", file,
                     file == "<input>" ? "input" : "exemplar", cx, cx * sx, cy * sy);
}

Heightfield amplify_from_exemplars(const Heightfield& low, const std::vector<Heightfield>& exemplars,
                                   const LearnOptions& learn, const AmplifyOptions& o, const Progress& progress) {
  require_finite(low, "amplify", "input");
  if (exemplars.empty()) fail("amplify", "no exemplar given");
  if (o.mode != "detail" && o.mode != "faithful") fail("amplify", "mode '{}' is not one of detail|faithful", o.mode);
  const int steps = steps_for(o.factor, learn.factor);
  const Georef& e = exemplars[0].georef;
  Heightfield cur = low;
  std::unique_ptr<Dictionary> dict;
  std::unique_ptr<BlockRegression> reg;
  std::vector<std::string> gains, notes, hf_notes;
  LearnOptions lo = learn;  // calibrate the gain for the search used here
  if (o.neighbours > 0) lo.calibration_neighbours = o.neighbours;
  lo.calibration_candidates = o.candidates;
  if (o.magnitude_weight >= 0) lo.calibration_magnitude_weight = o.magnitude_weight;
  if (o.blend != "auto") lo.calibration_blend = o.blend;
  if (o.base != "auto") lo.calibration_base = o.base;
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
      } else {
        dict = std::make_unique<Dictionary>(learn_dictionary(ex, lo, scaled_progress(pk, 0, 0.5)));
        notes.push_back(fmt::format("step {}: {}", k + 1, dict->description));
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
    cur = amplify_step(cur, *dict, r, index.get(), scaled_progress(pk, 0.5, 1), k == 0);
    gains.push_back(cur.metadata["amplify_detail_gain"]);
    if (cur.metadata.count("amplify_hf_calibration"))
      hf_notes.push_back(fmt::format("step {}: {}", k + 1, cur.metadata["amplify_hf_calibration"]));
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
  auto crop = [&](int a0, int a1, int o0, int o1) {  // [a0, a1) along the long axis, [o0, o1) across
    const int w = wide ? a1 - a0 : o1 - o0, h = wide ? o1 - o0 : a1 - a0;
    const int x0 = wide ? a0 : o0, y0 = wide ? o0 : a0;
    Heightfield c(w, h);
    c.georef = ex.georef;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) c.at(x, y) = ex.at(x0 + x, y0 + y);
    return c;
  };
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
