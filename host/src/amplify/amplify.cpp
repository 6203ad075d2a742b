// SPDX-License-Identifier: Apache-2.0
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

#include "amplify/amplify_internal.hpp"

namespace terracl {

namespace amplify_internal {

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

std::unique_ptr<AtomIndex> make_index(const Dictionary& d, const AmplifyOptions& o) {
  const bool s1 = o.sparsity == 1 && o.search != "omp";
  if (!s1) return nullptr;
  if (o.search == "flann" || (o.search == "auto" && d.atoms() > 4096))
    return std::make_unique<AtomIndex>(d.low, o.trees, o.checks, o.seed, &d.low_norm, o.magnitude_weight);
  return nullptr;
}

}  // namespace amplify_internal

using namespace amplify_internal;

namespace {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

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
  // rhos, gains, anisotropies and relief scales per step (older callers pass the first two or three);
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
