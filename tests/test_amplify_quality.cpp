// SPDX-License-Identifier: Apache-2.0
// Quality of amplification on real terrain: no trace of the patch grid, calibrated detail.
#include "test_helpers.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <random>
#include <utility>

using namespace terracl;

namespace {

Heightfield crop_of(const Heightfield& h, int x0, int y0, int w, int ht) {
  Heightfield c(w, ht);
  c.georef = h.georef;
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  return c;
}

// White noise whose amplitude is modulated by 1 + a cos(2 pi x / period) along x.
Heightfield modulated_noise(int n, int period, double a, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  Heightfield h(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h.at(x, y) = float(g(rng) * (1 + a * std::cos(2 * M_PI * x / period)));
  return h;
}

}  // namespace

TEST(AmplifyQuality, PeriodicTraceFindsAModulatedCurvature) {
  // The metric itself: +-10 % amplitude modulation of white noise with period 8 (+-20 % in the
  // squared curvature, the ripple) stands far above the spectrum around it; none does not.
  const PeriodicTrace none = periodic_trace(modulated_noise(256, 8, 0.0, 1), 8);
  const PeriodicTrace some = periodic_trace(modulated_noise(256, 8, 0.1, 1), 8);
  EXPECT_LT(none.peak, 8.0);
  EXPECT_LT(none.ripple, 0.12);
  EXPECT_GT(some.peak, 50.0);
  EXPECT_GT(some.ripple, 0.25);
}

TEST(AmplifyQuality, PeriodicTraceAveragedOverRastersKeepsASharedRipple) {
  // The seed-averaged criterion (dictionary evaluate --trace-seeds): the profiles' power spectra of
  // independent realisations are averaged before the peak is read. Noise alone then stays near 1
  // (a mean of 3 exponential variables), a ripple the rasters share keeps its peak, and one raster
  // gives what the single-raster trace gives.
  const Heightfield n1 = modulated_noise(256, 8, 0.0, 11), n2 = modulated_noise(256, 8, 0.0, 12),
                    n3 = modulated_noise(256, 8, 0.0, 13);
  const Heightfield m1 = modulated_noise(256, 8, 0.1, 11), m2 = modulated_noise(256, 8, 0.1, 12),
                    m3 = modulated_noise(256, 8, 0.1, 13);
  const PeriodicTrace none = periodic_trace(std::vector<const Heightfield*>{&n1, &n2, &n3}, 8);
  const PeriodicTrace some = periodic_trace(std::vector<const Heightfield*>{&m1, &m2, &m3}, 8);
  std::printf("averaged over 3: none %.2f, some %.1f; single: %.2f %.2f %.2f\n", none.peak, some.peak,
              periodic_trace(n1, 8).peak, periodic_trace(n2, 8).peak, periodic_trace(n3, 8).peak);
  EXPECT_LT(none.peak, 4.0);
  EXPECT_GT(some.peak, 50.0);
  EXPECT_GT(some.ripple, 0.25);
  const PeriodicTrace one = periodic_trace(std::vector<const Heightfield*>{&m2}, 8), ref = periodic_trace(m2, 8);
  EXPECT_EQ(one.peak, ref.peak);
  EXPECT_EQ(one.ripple, ref.ripple);
  const Heightfield small = modulated_noise(128, 8, 0.0, 1);
  EXPECT_THROW(periodic_trace(std::vector<const Heightfield*>{&n1, &small}, 8), Error);
  EXPECT_THROW(periodic_trace(std::vector<const Heightfield*>{}, 8), Error);
}

// x4 of `low` with a complete dictionary of `ex` at gain 2: the patch-spacing trace of the paper's
// average blend, and the detail blend's output.
static std::pair<PeriodicTrace, Heightfield> average_and_detail_blends(const Heightfield& ex, const Heightfield& low,
                                                                int max_patches) {
  LearnOptions l;
  l.method = "complete";
  l.max_patches = max_patches;
  l.calibrate = false;
  const Dictionary d = learn_dictionary({ex}, l);
  AmplifyOptions o;
  o.detail_gain = 2.0f;
  o.blend = "average";
  const PeriodicTrace avg = periodic_trace(amplify(low, d, o), 8);
  o.blend = "detail";
  return {avg, amplify(low, d, o)};
}

TEST(AmplifyQuality, DetailBlendLeavesNoPatchGridTrace) {
  // x4 of a 200^2 block-mean input of N44W072 (the exemplar: a disjoint part of the same DEM). The
  // paper's weighted average of the patches (the only blend before issue 16) fades detail between
  // patch centres: the squared curvature ripples with the patch spacing (8 cells; peak 40 here, 47
  // with the bicubic base). The detail blend must leave no peak at the spacing (5.2 here, 5.4 with the
  // bicubic base). The block-size trace (4 cells; 19 here, 59 with the bicubic base; docs/amplify.md)
  // is not asserted.
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield ex = crop_of(dem, 0, 0, 256, 256);
  const Heightfield truth = crop_of(dem, 400, 400, 800, 800);
  const Heightfield low = block_mean(truth, 4);
  const auto [avg, out] = average_and_detail_blends(ex, low, 6000);
  const PeriodicTrace det = periodic_trace(out, 8), blk = periodic_trace(out, 4);
  std::printf("average blend: peak %.1f ripple %.3f; detail blend: peak %.1f ripple %.3f, block peak %.1f ripple %.3f\n",
              avg.peak, avg.ripple, det.peak, det.ripple, blk.peak, blk.ripple);
  EXPECT_GT(avg.peak, 20.0) << "ripple " << avg.ripple;
  EXPECT_LT(det.peak, 8.0) << "ripple " << det.ripple;
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
}

TEST(AmplifyQuality, DetailBlendLeavesNoPatchGridTraceOnAFrontRangeCrop) {
  // The Front Range's detail is weak (gain ~2 on gentle relief) and anisotropic (ridges run
  // north-south). On this crop (x4 of 94^2 input cells) the paper's average blend shows the patch
  // spacing and the detail blend does not. On the whole DEM's x4 the band-limited base took the peak
  // at the spacing from 15.1 to 5.4 and the block-size one from 73.6 to 25.6 (docs/amplify.md).
  const Heightfield dem = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  const Heightfield ex = crop_of(dem, 0, 0, 360, 360);
  const Heightfield truth = crop_of(dem, 376, 0, 376, 376);
  const Heightfield low = block_mean(truth, 4);
  const auto [avg, out] = average_and_detail_blends(ex, low, 8000);
  const PeriodicTrace det = periodic_trace(out, 8);
  std::printf("Front Range crop: average blend peak %.1f; detail blend peak %.1f ripple %.3f (rho %s)\n", avg.peak,
              det.peak, det.ripple, out.metadata.at("amplify_detail_correlation").c_str());
  EXPECT_GT(avg.peak, 15.0) << "ripple " << avg.ripple;  // 29.7 (bicubic base: 21.8)
  EXPECT_LT(det.peak, 8.0) << "ripple " << det.ripple;  // 1.7 (bicubic base: 4.2)
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
}

TEST(AmplifyQuality, SeedAveragedTraceStillFindsTheAverageBlendsRipple) {
  // The evaluation's seed-averaged pk S (docs/amplify.md) must still fail the
  // output the trace test was written against: the paper's average blend, here over seeds 1-3 (each
  // seed its own training subset and FLANN forest), on the N44W072 crop of
  // DetailBlendLeavesNoPatchGridTrace; the detail blend stays under the threshold.
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield ex = crop_of(dem, 0, 0, 256, 256);
  const Heightfield low = block_mean(crop_of(dem, 400, 400, 800, 800), 4);
  std::vector<Heightfield> avg, det;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    LearnOptions l;
    l.method = "complete";
    l.max_patches = 6000;
    l.calibrate = false;
    l.seed = seed;
    const Dictionary d = learn_dictionary({ex}, l);
    AmplifyOptions o;
    o.detail_gain = 2.0f;
    o.seed = seed;
    o.blend = "average";
    avg.push_back(amplify(low, d, o));
    o.blend = "detail";
    det.push_back(amplify(low, d, o));
  }
  auto trace = [](const std::vector<Heightfield>& v) {
    return periodic_trace(std::vector<const Heightfield*>{&v[0], &v[1], &v[2]}, 8);
  };
  const PeriodicTrace a = trace(avg), b = trace(det);
  std::printf("seed-averaged trace: average blend %.1f, detail blend %.1f\n", a.peak, b.peak);
  EXPECT_GT(a.peak, 20.0) << "ripple " << a.ripple;  // 25.2
  // 7.5: seeds 2 and 3 carry more of the small x4 ripple than seed 1 (5.2 alone); close to the
  // threshold, as the x4 Front Range's 5.6 in the evaluation.
  EXPECT_LT(b.peak, 8.0) << "ripple " << b.ripple;
}

TEST(AmplifyQuality, AnisotropicDetailCorrelationRemovesTheFrontRangeX16Ripple) {
  // The evaluation's x16 of the Front Range (east half's 16 x 16 block means, 23 x 47 cells; the west
  // half the exemplar, a dictionary per step), here at a fixed gain 2 per step: one measured rho left
  // the second step's patch spacing in the squared curvature along y (the north-south ridges'
  // details correlate more across y-neighbour overlaps than across x-neighbour ones); the measured
  // anisotropy removes it. Block means stay exact with both.
  const Heightfield dem = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  const int half = dem.width / 2, w = half / 16 * 16, h = dem.height / 16 * 16;
  const Heightfield west = crop_of(dem, 0, 0, half, dem.height);
  const Heightfield low = block_mean(crop_of(dem, dem.width - w, 0, w, h), 16);
  LearnOptions l;
  l.method = "complete";
  l.calibrate = false;
  l.faithful_radius = 0;
  AmplifyOptions o;
  o.factor = 16;
  o.detail_gain = 2.0f;
  o.detail_anisotropy = false;
  const Heightfield iso = amplify_from_exemplars(low, {west}, l, o);
  o.detail_anisotropy = true;
  const Heightfield aniso = amplify_from_exemplars(low, {west}, l, o);
  const PeriodicTrace a = periodic_trace(iso, 8), b = periodic_trace(aniso, 8);
  std::printf("x16 Front Range, gain 2: one rho (%s) peak %.1f; anisotropic (%s) peak %.1f\n",
              iso.metadata.at("amplify_detail_correlation").c_str(), a.peak,
              aniso.metadata.at("amplify_detail_correlation").c_str(), b.peak);
  EXPECT_GT(a.peak, 8.0) << "ripple " << a.ripple;
  EXPECT_LT(b.peak, 8.0) << "ripple " << b.ripple;
  const Heightfield m = block_mean(aniso, 16);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
}

namespace {
double rmse_of(const Heightfield& a, const Heightfield& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += double(a.z[i] - b.z[i]) * (a.z[i] - b.z[i]);
  return std::sqrt(s / double(a.size()));
}
}  // namespace

TEST(AmplifyQuality, FaithfulRegressionBeatsBicubicOnHeldOutTerrain) {
  // The regression is the least-squares linear upsampler of the exemplar, and bicubic is one linear
  // upsampler in its span: on the exemplar itself it cannot do worse; on held-out terrain of the same
  // DEM it should do clearly better (the target: <= 0.95 x bicubic).
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield ex = crop_of(dem, 0, 0, 320, 320);
  const Heightfield truth = crop_of(dem, 640, 640, 256, 256);
  for (int radius : {2, 3}) {
    const BlockRegression g = learn_block_regression({ex}, 4, radius);
    const Heightfield train_low = block_mean(ex, 4);
    EXPECT_LE(rmse_of(apply_block_regression(train_low, g), ex), rmse_of(bicubic_upsample(train_low, 4), ex));
    const Heightfield low = block_mean(truth, 4);
    const Heightfield out = apply_block_regression(low, g);
    const double ratio = rmse_of(out, truth) / rmse_of(bicubic_upsample(low, 4), truth);
    EXPECT_LT(ratio, 0.95) << "radius " << radius;
    // Block means exact without any correction (the weights of every block sum to zero).
    const Heightfield m = block_mean(out, 4);
    for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 2e-3f);
  }
}

TEST(AmplifyQuality, FaithfulModeCascadesAndReportsInMetadata) {
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield ex = crop_of(dem, 0, 0, 600, 600);
  const Heightfield truth = crop_of(dem, 640, 640, 256, 256);
  LearnOptions l;
  l.method = "complete";
  AmplifyOptions o;
  o.mode = "faithful";
  o.factor = 16;
  const Heightfield low = block_mean(truth, 16);
  const Heightfield out = amplify_from_exemplars(low, {ex}, l, o);
  ASSERT_EQ(out.width, 256);
  EXPECT_LT(rmse_of(out, truth), rmse_of(bicubic_upsample(low, 16), truth));
  const Heightfield m = block_mean(out, 16);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
  EXPECT_EQ(out.metadata.at("amplify_mode"), "faithful");
  EXPECT_NE(out.metadata.at("amplify_calibration").find("step 2: regression"), std::string::npos)
      << out.metadata.at("amplify_calibration");
  // A dictionary learned without the regression: a clear error, not a silent detail amplification.
  const Dictionary d = learn_dictionary(
      {ex}, [] { LearnOptions c; c.method = "complete"; c.calibrate = false; c.max_patches = 2000; c.faithful_radius = 0; return c; }());
  try {
    amplify(block_mean(truth, 4), d, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--exemplar"), std::string::npos) << e.what();
  }
}

TEST(AmplifyQuality, BandlimitedBaseHasNoKnotTrace) {
  // The bicubic base's curvature peaks at the input cells' centres (the cubic's knots): a strong
  // trace with the block period. The band-limited base is consistent (block means ~ the input) and
  // has (almost) none; it reproduces linear ramps away from the borders.
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield low = block_mean(crop_of(dem, 400, 400, 480, 480), 4);
  const double bic = periodic_trace(upsample(low, 4, "bicubic"), 4).peak;
  Heightfield band = upsample(low, 4, "bandlimited");
  const double raw = periodic_trace(band, 4).peak;
  double worst = 0;
  const Heightfield m = block_mean(band, 4);
  for (size_t i = 0; i < m.size(); ++i) worst = std::max(worst, double(std::fabs(m.z[i] - low.z[i])));
  correct_block_means(band, low, 4, 4, "bandlimited");
  const double corrected = periodic_trace(band, 4).peak;
  std::printf("block-period peak: bicubic %.1f, band-limited %.1f (corrected %.1f); block means within %.3f m\n", bic, raw,
              corrected, worst);
  EXPECT_GT(bic, 200.0);
  EXPECT_LT(raw, bic / 5);
  EXPECT_LT(corrected, bic / 5);
  EXPECT_LT(worst, 2.0);  // truncated kernel (16 taps); the correction makes them exact
  const Heightfield cm = block_mean(band, 4);
  for (size_t i = 0; i < cm.size(); ++i) ASSERT_NEAR(cm.z[i], low.z[i], 1e-2f);
  Heightfield ramp(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) ramp.at(x, y) = float(3 * x - 2 * y);
  const Heightfield up = upsample(ramp, 4, "bandlimited");
  for (int Y = 40; Y < 80; ++Y)
    for (int X = 40; X < 120; ++X)
      ASSERT_NEAR(up.at(X, Y), 3 * ((X + 0.5) / 4 - 0.5) - 2 * ((Y + 0.5) / 4 - 0.5), 2e-3) << X << "," << Y;
}

TEST(AmplifyQuality, BandlimitedBaseIsTheDefaultAndRecordedInTheDictionary) {
  // Learned now: the band-limited base (calibrated for it, flag bit 4 of format version 3); the
  // output names its base; an explicit --base bicubic still works; a bad name is a clear error.
  const Heightfield dem = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  const Heightfield ex = crop_of(dem, 0, 0, 200, 200);
  LearnOptions l;
  l.method = "complete";
  l.max_patches = 3000;
  l.calibrate = false;
  const Dictionary d = learn_dictionary({ex}, l);
  EXPECT_EQ(d.base, "bandlimited");
  test::TempDir tmp;
  save_dictionary(d, tmp.path("d.tdic"));
  EXPECT_EQ(load_dictionary(tmp.path("d.tdic")).base, "bandlimited");
  const Heightfield low = block_mean(crop_of(dem, 400, 0, 256, 256), 4);
  AmplifyOptions o;
  const Heightfield a = amplify(low, d, o);
  EXPECT_EQ(a.metadata.at("amplify_base"), "bandlimited");
  o.base = "bicubic";
  const Heightfield b = amplify(low, d, o);
  EXPECT_EQ(b.metadata.at("amplify_base"), "bicubic");
  EXPECT_NE(0, std::memcmp(a.z.data(), b.z.data(), a.size() * sizeof(float)));
  for (const Heightfield* h : {&a, &b}) {
    const Heightfield m = block_mean(*h, 4);
    for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 1e-2f);
  }
  o.base = "spline";
  EXPECT_THROW(amplify(low, d, o), Error);
}

TEST(AmplifyQuality, ReliefExponentIsFittedOnTheDictionarysAtoms) {
  // Atoms whose source detail is |L|^0.4 (a checkerboard inside each 4 x 4 block: zero block means,
  // so it is all detail with either base): b = 1 - 0.4.
  Dictionary d;
  d.patch = 16, d.factor = 4;
  const int n = 64;
  d.high.resize(16 * 16, n);
  d.low = MatrixF::Constant(4 * 4, n, 0.25f);
  for (int j = 0; j < n; ++j) {
    const float norm = std::exp(float(j) / 16.f);
    d.low_norm.push_back(norm);
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) d.high(y * 16 + x, j) = ((x + y) % 2 ? 1.f : -1.f) * std::pow(norm, 0.4f) / norm;
  }
  EXPECT_NEAR(detail_relief_exponent(d, "bandlimited"), 0.6, 1e-3);
  EXPECT_NEAR(detail_relief_exponent(d, "bicubic"), 0.6, 1e-3);
  d.low_norm.clear();  // K-SVD atoms carry no source relief
  EXPECT_EQ(detail_relief_exponent(d, "bandlimited"), -1.0);
}

TEST(AmplifyQuality, LaterCascadeStepScalesDetailByTheExemplarsReliefOverTheInputs) {
  // x16 of a N44W072 input and of the same input at half the relief, with a dictionary of another part
  // of the DEM and a fixed gain. The atom search ties detail to each footprint's relief (detail ~
  // relief^(1 - b)); the second step's gain is multiplied by (q_ref / q_med)^b, so the gentler input's
  // second-step detail is ~2^b (energy 2^2b) larger, relative to the full input's, than without the
  // scale (issue 16 session 10: the Front Range's east half is gentler than its exemplar and got 0.66 of
  // the truth's gradient energy at 1/8-1/2 cycles per cell before, 1.19-1.22 after). Measured: b 0.652, scales 0.798
  // / 1.211 (ratio 1.518), energy ratio 1.134 against 0.510 without the scale.
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  LearnOptions l;
  l.max_patches = 6000;
  l.calibrate = false;
  l.faithful_radius = 0;
  const Dictionary d = learn_dictionary({crop_of(dem, 0, 0, 256, 256)}, l);
  const double b = detail_relief_exponent(d, d.base);
  EXPECT_GT(b, 0.3);  // measured 0.652 (the whole west half: 0.494)
  EXPECT_LT(b, 0.8);
  const Heightfield full = block_mean(crop_of(dem, 600, 600, 320, 320), 16);
  Heightfield gentle = full;
  for (auto& v : gentle.z) v *= 0.5f;
  AmplifyOptions o;
  o.factor = 16;
  o.detail_gain = 2;
  AmplifyOptions off = o;
  off.cascade_relief_exponent = 0;
  const Heightfield a = amplify(full, d, o), g = amplify(gentle, d, o);
  const Heightfield a0 = amplify(full, d, off), g0 = amplify(gentle, d, off);
  auto scale = [](const Heightfield& h) {
    const std::string& r = h.metadata.at("amplify_relief_scale");
    EXPECT_NE(r.find("step 2:"), std::string::npos) << r;
    return std::stod(r.substr(r.find("detail x ") + 9));
  };
  const double sa = scale(a), sg = scale(g);
  EXPECT_EQ(a0.metadata.count("amplify_relief_scale"), 0u);
  AmplifyOptions x4 = o;
  x4.factor = 4;
  EXPECT_EQ(amplify(full, d, x4).metadata.count("amplify_relief_scale"), 0u);  // one step: unscaled
  // The second step's band (above the first step's output Nyquist).
  const double on = energy_above(g, 4) / energy_above(a, 4), was = energy_above(g0, 4) / energy_above(a0, 4);
  std::printf("b %.3f; relief scales %.3f (full), %.3f (half relief): ratio %.3f (2^b %.3f); second-step energy, "
              "half over full relief: %.3f, without the scale %.3f\n", b, sa, sg, sg / sa, std::pow(2.0, b), on, was);
  EXPECT_NEAR(sg / sa, std::pow(2.0, b), 0.1 * std::pow(2.0, b));
  EXPECT_NEAR(on / was, (sg / sa) * (sg / sa), 0.25 * (sg / sa) * (sg / sa));
  EXPECT_GT(on / was, 1.3);
  // Block means stay exact; the same input gives the same bits.
  const Heightfield m = block_mean(g, 16);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], gentle.z[i], 1e-2f);
  EXPECT_TRUE(amplify(gentle, d, o).z == g.z);
}
