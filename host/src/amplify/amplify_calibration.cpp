// SPDX-License-Identifier: Apache-2.0
// What each step of an amplification measures on the whole input before any tile is made: the
// detail blend's correlation and anisotropy, a later cascade step's relief scale, and the per-input
// HF gain, so that tiled and untiled runs use the same values.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "amplify/amplify_internal.hpp"
#include "amplify/step_engine.hpp"

namespace terracl::amplify_internal {
namespace {

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


// Per-input HF calibration (docs/amplify.md, "per-input HF"): the gain whose output HF energy, on
// the first step's measured region (rho_region: the central (up to) 256 x 256 input cells, here
// cells [lx0, lx0 + cw) x [ly0, ly0 + ch) of the window `low`), is the geometric mean of two estimates of the truth's:
// the held-out folds' (the output's HF at the dictionary's HF-matching gain over its HF target) and
// the input's own spectrum extrapolated (predicted_energy_above, scaled by the ratio the folds
// measured). Their errors are independent (the folds know the dictionary, the spectrum knows this
// terrain). Capped by the folds' RMSE-budget gain. `detail` is the region's blended detail before
// the gain (amplify_step's raw output there, cw f x ch f cells); -1 when the dictionary carries no in-memory calibration
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
    for (int x = 0; x < cw * f; ++x) cd.at(x, y) = cb.at(x, y) + detail.at(x, y);
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

}  // namespace

// Correlations rho of every step (detail blend; empty otherwise), each measured on its step's
// rho_region: the input of step k > 0 there is the previous steps' output over that region's
// footprint, amplified from a window of the input with the rhos found so far. Then the gain per step
// chosen for this input (input_hf_gain: the first step of a cascade only, `first_is_input`; -1 for
// the dictionary's or the options' gain), then the anisotropy delta per step (measure_rho; 0 with a
// fixed rho): the result holds `steps` rhos, `steps` gains, `steps` deltas. A function of the whole
// input only, so tiles and the untiled run use the same values.
std::vector<float> step_correlations(const AmplifyWindowReader& read, int width, int height, int steps,
                                     const Dictionary& d, const AmplifyOptions& o, const AtomIndex* index,
                                     bool first_is_input) {
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
    // The region in the window's output cells.
    const int X0 = (r.x0 - a0) * f, Y0 = (r.y0 - b0) * f, X1 = (r.x1 - a0) * f, Y1 = (r.y1 - b0) * f;
    const bool gain_here = k == 0 && input_gain;
    BlendSums sums;  // measure_rho's blend, which the gain's raw detail reuses
    const auto [rho, delta] = fixed_rho ? std::pair<float, float>{std::clamp(o.detail_correlation, 0.f, 1.f), 0.f}
                                        : eng.measure_rho(X0, Y0, X1, Y1, gain_here ? &sums : nullptr);
    rhos.push_back(rho);
    deltas[size_t(k)] = delta;
    if (gain_here) {
      Heightfield detail(X1 - X0, Y1 - Y0);
      if (!sums.num.empty()) {
        const bool aniso = delta != 0.f && eng.anisotropic();
        parallel_for(size_t(detail.height), o.threads, [&](size_t y0, size_t y1) {
          for (int y = int(y0); y < int(y1); ++y)
            for (int x = 0; x < detail.width; ++x) {
              const size_t c = size_t(Y0 - sums.y0 + y) * sums.w + size_t(X0 - sums.x0 + x);
              detail.at(x, y) = blended_value(sums.num[c], sums.den[c], sums.den1[c], aniso ? sums.uv[2 * c] : 0.f,
                                              aniso ? sums.uv[2 * c + 1] : 0.f, rho, delta, true, aniso);
            }
        });
      } else {
        const Heightfield raw = amplify_step(win, a0, b0, k, rho, delta, d, o, index, {}, -1, 1, true);
        for (int y = 0; y < detail.height; ++y)
          for (int x = 0; x < detail.width; ++x) detail.at(x, y) = raw.at(X0 + x, Y0 + y);
      }
      gains[0] = float(input_hf_gain(win, r.x0 - a0, r.y0 - b0, r.x1 - r.x0, r.y1 - r.y0, detail, d, o.base));
    }
  }
  rhos.insert(rhos.end(), gains.begin(), gains.end());
  rhos.insert(rhos.end(), deltas.begin(), deltas.end());
  rhos.insert(rhos.end(), reliefs.begin(), reliefs.end());
  return rhos;
}

}  // namespace terracl::amplify_internal
