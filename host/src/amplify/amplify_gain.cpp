// SPDX-License-Identifier: Apache-2.0
// The detail gain of a dictionary, calibrated on its exemplar's held-out folds (calibrate_detail):
// the gain whose output carries the truth's HF energy, capped by an RMSE budget against bicubic.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "amplify/amplify_internal.hpp"

namespace terracl {

namespace amplify_internal {

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

}  // namespace amplify_internal

using namespace amplify_internal;

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

}  // namespace terracl
