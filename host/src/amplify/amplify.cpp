// Amplification by a multi-resolution dictionary (sparse terrain paper, section 5.3): each output
// patch's low-resolution footprint is decomposed over L, the same coefficients applied to H, and the
// patches blended with the disc weights; then the block means are corrected to match the input.
// The output is produced tile by tile (only the tile's patches, codes and blend buffers are held).
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace terracl {

namespace {

inline int clampi(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

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
  if (o.search != "auto" && o.search != "flann" && o.search != "exact" && o.search != "omp")
    fail("amplify", "search '{}' is not one of auto|flann|exact|omp", o.search);
}

// One x f step.
Heightfield amplify_step(const Heightfield& low, const Dictionary& d, const AmplifyOptions& o, const AtomIndex* index,
                         const Progress& progress) {
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
  const int tile = std::max(S, o.tile / S * S);
  const int tx = (W + tile - 1) / tile, ty = (H + tile - 1) / tile;
  // Patch k covers output cells [k S - Q, k S - Q + P); its low-resolution footprint starts at (k S - Q) / f.
  auto first = [&](int a) { int k = 0; while (k * S - Q + P <= a) ++k; return k; };
  auto last = [&](int b) { int k = 0; while (k * S - Q < b) ++k; return k; };  // exclusive
  const int phases = (P + S - 1) / S;  // patch rows this far apart never overlap

  for (int j = 0; j < ty; ++j)
    for (int i = 0; i < tx; ++i) {
      const int X0 = i * tile, X1 = std::min(W, X0 + tile), Y0 = j * tile, Y1 = std::min(H, Y0 + tile);
      const int kx0 = first(X0), kx1 = last(X1), ky0 = first(Y0), ky1 = last(Y1);
      const int nx = kx1 - kx0, ny = ky1 - ky0;
      const size_t m = size_t(nx) * ny;
      MatrixF q(p * p, Eigen::Index(m));
      std::vector<float> z(m);
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
      SparseCodes codes;
      if (use_omp) {
        codes = batch_omp(d.low, q, o.sparsity, o.threads);
      } else {
        AtomMatch a = index ? index->search(q, o.threads) : exact_atom_search(d.low, q, o.threads);
        codes.sparsity = 1;
        codes.index = std::move(a.index);
        codes.coef = std::move(a.coef);
      }
      const int s = codes.sparsity;
      const int tw = X1 - X0, th = Y1 - Y0;
      std::vector<float> num(size_t(tw) * th, 0.f), den(num.size(), 0.f);
      for (int ph = 0; ph < phases; ++ph) {
        std::vector<int> rows;
        for (int r = ph; r < ny; r += phases) rows.push_back(r);
        parallel_for(rows.size(), o.threads, [&](size_t b, size_t e) {
          for (size_t ri = b; ri < e; ++ri) {
            const int r = rows[ri];
            for (int cx = 0; cx < nx; ++cx) {
              const size_t c = size_t(r) * nx + cx;
              const int px = (kx0 + cx) * S - Q - X0, py = (ky0 + r) * S - Q - Y0;
              for (int v = std::max(0, -py); v < P && py + v < th; ++v)
                for (int u = std::max(0, -px); u < P && px + u < tw; ++u) {
                  const int k = v * P + u;
                  const float w = weights[k];
                  if (w == 0.f) continue;
                  float val = z[c];
                  for (int t = 0; t < s; ++t) {
                    const int a = codes.index[c * s + t];
                    if (a >= 0) val += codes.coef[c * s + t] * d.high(k, a);
                  }
                  const size_t o2 = size_t(py + v) * tw + px + u;
                  num[o2] += w * val;
                  den[o2] += w;
                }
            }
          }
        });
      }
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const float dn = den[size_t(y) * tw + x];
          if (!(dn > 0)) fail("amplify", "spacing {} leaves cells uncovered by {}-cell patches", S, P);
          out.at(X0 + x, Y0 + y) = num[size_t(y) * tw + x] / dn;
        }
      report_progress(progress, "amplify", double(j * tx + i + 1) / (tx * ty), fmt::format("tile {}/{}", j * tx + i + 1, tx * ty));
    }
  const float gain = o.detail_gain < 0 ? d.detail_gain : o.detail_gain;
  if (gain != 1.f) {
    // out = bicubic + gain (out - bicubic)
    for (auto& v : out.z) v *= gain;
    add_bicubic(out, low, f, 1.f - gain);
  }
  if (o.bias_correction) correct_block_means(out, low, f);
  return out;
}

std::unique_ptr<AtomIndex> make_index(const Dictionary& d, const AmplifyOptions& o) {
  const bool s1 = o.sparsity == 1 && o.search != "omp";
  if (!s1) return nullptr;
  if (o.search == "flann" || (o.search == "auto" && d.atoms() > 4096))
    return std::make_unique<AtomIndex>(d.low, o.trees, o.checks, o.seed);
  return nullptr;
}

}  // namespace

Heightfield amplify(const Heightfield& low, const Dictionary& d, const AmplifyOptions& o, const Progress& progress) {
  require_finite(low, "amplify", "input");
  check_options(o, d);
  if (d.factor < 2) fail("amplify", "the dictionary has factor {}: amplification needs a multi-resolution dictionary", d.factor);
  const int steps = steps_for(o.factor, d.factor);
  const auto index = make_index(d, o);
  Heightfield cur = low;
  for (int k = 0; k < steps; ++k)
    cur = amplify_step(cur, d, o, index.get(), scaled_progress(progress, double(k) / steps, double(k + 1) / steps));
  return cur;
}

Heightfield amplify_from_exemplars(const Heightfield& low, const std::vector<Heightfield>& exemplars,
                                   const LearnOptions& learn, const AmplifyOptions& o, const Progress& progress) {
  require_finite(low, "amplify", "input");
  if (exemplars.empty()) fail("amplify", "no exemplar given");
  const int steps = steps_for(o.factor, learn.factor);
  const Georef& e = exemplars[0].georef;
  Heightfield cur = low;
  std::unique_ptr<Dictionary> dict;
  for (int k = 0; k < steps; ++k) {
    const double tx = cur.georef.cell_x / learn.factor, ty = cur.georef.cell_y / learn.factor;
    const double rx = tx / e.cell_x, ry = ty / e.cell_y;
    const Progress pk = scaled_progress(progress, double(k) / steps, double(k + 1) / steps);
    if (rx < 0.95 || ry < 0.95) {
      // The exemplar has no detail this fine: reuse the finest dictionary (self-similarity).
      if (!dict)
        fail("amplify", "mismatched cell sizes: the exemplar's {:.3f} x {:.3f} m cells are coarser than the output's "
             "{:.3f} x {:.3f} m", e.cell_x, e.cell_y, tx, ty);
    } else {
      const int r = int(std::lround(rx));
      if (std::fabs(rx - r) > 0.05 * rx || std::fabs(ry - r) > 0.05 * ry)
        fail("amplify", "mismatched cell sizes: output cells {:.3f} x {:.3f} m are not a whole multiple of the exemplar's "
             "{:.3f} x {:.3f} m", tx, ty, e.cell_x, e.cell_y);
      std::vector<Heightfield> ex;
      for (const auto& h : exemplars) ex.push_back(r > 1 ? block_mean(h, r) : h);
      dict = std::make_unique<Dictionary>(learn_dictionary(ex, learn, scaled_progress(pk, 0, 0.5)));
    }
    check_options(o, *dict);
    const auto index = make_index(*dict, o);
    cur = amplify_step(cur, *dict, o, index.get(), scaled_progress(pk, 0.5, 1));
  }
  return cur;
}

// Gain range, and the RMSE the calibration may spend (relative to bicubic's on the held-out half)
// to restore relief; 1.15 leaves a margin under the evaluation target (1.2) for the exemplar-to-input transfer.
constexpr double kMinGain = 0.5, kMaxGain = 2.0, kRmseBudget = 1.15;

double calibrate_detail_gain(const Heightfield& ex, const LearnOptions& o) {
  const int f = o.factor;
  // Split along the longer axis; each half must hold several patches.
  const bool wide = ex.width >= ex.height;
  const int half = (wide ? ex.width : ex.height) / 2;
  const int other = wide ? ex.height : ex.width;
  if (half < 4 * o.patch || other < 4 * o.patch) return 1.0;
  auto crop = [&](int x0, int y0, int w, int h) {
    Heightfield c(w, h);
    c.georef = ex.georef;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) c.at(x, y) = ex.at(x0 + x, y0 + y);
    return c;
  };
  const int bw = (wide ? half : ex.width) / f * f, bh = (wide ? ex.height : half) / f * f;
  const Heightfield a = wide ? crop(0, 0, half, ex.height) : crop(0, 0, ex.width, half);
  const Heightfield b = wide ? crop(ex.width - bw, 0, bw, bh) : crop(0, ex.height - bh, bw, bh);
  const Dictionary d = learn_dictionary({a}, o);
  const Heightfield low = block_mean(b, f);
  AmplifyOptions ao;
  ao.factor = f;
  ao.spacing = o.calibration_spacing;
  ao.sparsity = o.sparsity;
  ao.detail_gain = 1;
  ao.bias_correction = false;
  ao.threads = o.threads;
  ao.seed = o.seed;
  const Heightfield out = amplify(low, d, ao);
  // The output is bicubic + g detail followed by the bias correction C, which is affine
  // (back-projection and block shifts), so C(bic + g det) = cb + g cd with cb = C(bic) and
  // cd = C(out) - cb: two corrections give every candidate gain exactly, as the default output.
  Heightfield cb = bicubic_upsample(low, f);
  const std::vector<float> bic = cb.z;
  correct_block_means(cb, low, f);
  Heightfield co = out;
  correct_block_means(co, low, f);
  std::vector<float> cd(co.z.size());
  for (size_t i = 0; i < cd.size(); ++i) cd[i] = co.z[i] - cb.z[i];
  // Roughness (the high-pass is linear): solve |hp(cb) + g hp(cd)| = |hp(truth)|.
  const auto hb = highpass(cb, f), ho = highpass(co, f), ht = highpass(b, f);
  double aa = 0, ab = 0, bb = 0, tt = 0;
  for (size_t i = 0; i < hb.size(); ++i) {
    const double det = ho[i] - hb[i];
    aa += hb[i] * hb[i], ab += hb[i] * det, bb += det * det, tt += ht[i] * ht[i];
  }
  if (!(bb > 0)) return 1.0;
  const double disc = ab * ab - bb * (aa - tt);
  const double g_rough = disc > 0 ? (-ab + std::sqrt(disc)) / bb : 1.0;
  // Spend the RMSE budget on relief: the largest g with |e0 + g cd|^2 <= (budget * rmse_bic)^2,
  // e0 = cb - truth (the larger root of the quadratic), but never less than the roughness gain.
  // Matching roughness alone leaves the mean slope short on some terrains (Front Range: 0.94).
  double e2 = 0, ed = 0, d2 = 0, r2 = 0;
  for (size_t i = 0; i < cd.size(); ++i) {
    const double e0 = double(cb.z[i]) - b.z[i], rb = double(bic[i]) - b.z[i];
    e2 += e0 * e0, ed += e0 * cd[i], d2 += double(cd[i]) * cd[i], r2 += rb * rb;
  }
  const double lim = kRmseBudget * kRmseBudget * r2;
  const double q = ed * ed - d2 * (e2 - lim);
  const double g_rmse = (d2 > 0 && q > 0) ? (-ed + std::sqrt(q)) / d2 : g_rough;
  const double g = std::max(g_rough, g_rmse);
  return std::clamp(g, kMinGain, kMaxGain);
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
