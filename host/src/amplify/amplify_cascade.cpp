// SPDX-License-Identifier: Apache-2.0
// Amplification with exemplars learned in the run (amplify_from_exemplars): one dictionary per
// step at that step's cell size, and for x16 the first step's gain chosen end to end on the
// exemplar's held-out folds (cascade_first_gain).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "amplify/amplify_internal.hpp"

namespace terracl {

using namespace amplify_internal;

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

}  // namespace terracl
