// SPDX-License-Identifier: Apache-2.0
// One step of amplification (amplify_step): the engine's blended patches, normalised for their
// overlap, then the gain, the base and the bias correction.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "amplify/amplify_internal.hpp"
#include "amplify/simd_clones.hpp"
#include "amplify/step_engine.hpp"

namespace terracl::amplify_internal {

// Bounds of the relief scale of a later cascade step (amplify_step).
constexpr float kMinReliefScale = 0.5f, kMaxReliefScale = 2.f;

TERRACL_SIMD_CLONES void add_patch_row(const float* w, const float* src, int u0, int u1, float* __restrict num,
                                       float* __restrict den, float* __restrict den1, float* uv, float uv_sign) {
  for (int u = u0; u < u1; ++u) num[u] += w[u] * src[u];
  if (den1) {
    for (int u = u0; u < u1; ++u) den[u] += w[u] * w[u];
    for (int u = u0; u < u1; ++u) den1[u] += w[u];
  } else {
    for (int u = u0; u < u1; ++u) den[u] += w[u];
  }
  if (uv)
    for (int u = u0; u < u1; ++u) uv[2 * u] += uv_sign * w[u];
}

// h *= gain, rows in parallel.
void scale_cells(Heightfield& h, float gain, int threads) {
  parallel_for(size_t(h.height), threads, [&](size_t y0, size_t y1) {
    for (float *v = h.z.data() + y0 * h.width, *e = h.z.data() + y1 * h.width; v < e; ++v) *v *= gain;
  });
}

// The output of one step over the window `low` (first cell: the step input's global cell ox, oy),
// with the detail blend's correlation rho (detail blend only).
// `input_gain` > 0: the gain chosen for this input (input_hf_gain) where the options leave it open;
// `raw`: the blended detail only (no gain, base or bias correction), what input_hf_gain measures.
Heightfield amplify_step(const Heightfield& low, int ox, int oy, int step, float rho, float delta, const Dictionary& d,
                         const AmplifyOptions& o, const AtomIndex* index, const Progress& progress,
                         float input_gain, float relief, bool raw) {
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
      parallel_for(size_t(th), o.threads, [&](size_t y0, size_t y1) {
        for (int y = int(y0); y < int(y1); ++y)
          for (int x = 0; x < tw; ++x) {
            const size_t c = size_t(y) * tw + x;
            const float dn = den[c];
            if (!(dn > 0)) fail("amplify", "spacing {} leaves cells uncovered by {}-cell patches", S, d.patch);
            out.at(X0 + x, Y0 + y) =
                blended_value(num[c], dn, detail_blend ? den1[c] : 0.f, aniso ? uv[2 * c] : 0.f,
                              aniso ? uv[2 * c + 1] : 0.f, rho, delta, detail_blend, aniso);
          }
      });
      report_progress(progress, "amplify", double(j * tx + i + 1) / (tx * ty), fmt::format("tile {}/{}", j * tx + i + 1, tx * ty));
    }
  // The last tile's sums (up to 5 floats per cell of a tile) are not needed by what follows.
  for (auto* v : {&num, &den, &den1, &uv}) std::vector<float>().swap(*v);
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
    if (gain != 1.f) scale_cells(out, gain, o.threads);
    add_upsampled(out, low, f, 1.f, o.base);
  } else if (gain != 1.f) {
    // out = base + gain (out - base)
    scale_cells(out, gain, o.threads);
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

}  // namespace terracl::amplify_internal
