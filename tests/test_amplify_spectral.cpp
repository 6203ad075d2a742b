// SPDX-License-Identifier: Apache-2.0
// Per-input HF calibration: the power-law prediction of the energy above the input's
// Nyquist, and the first step's gain that matches it with the held-out folds' estimate.
#include "test_helpers.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>
#include <unsupported/Eigen/FFT>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <complex>
#include <random>

using namespace terracl;

namespace {

// Periodic Gaussian field with power spectrum |k|^beta (spectral synthesis: white noise filtered).
Heightfield power_law_field(int n, double beta, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<std::complex<double>> grid(size_t(n) * n), out;
  std::vector<std::complex<double>> in(static_cast<size_t>(n));
  for (auto& c : grid) c = g(rng);
  Eigen::FFT<double> fft;
  auto pass = [&](bool forward) {
    for (int y = 0; y < n; ++y) {  // rows
      in.assign(grid.begin() + size_t(y) * n, grid.begin() + size_t(y + 1) * n);
      forward ? fft.fwd(out, in) : fft.inv(out, in);
      std::copy(out.begin(), out.end(), grid.begin() + size_t(y) * n);
    }
    for (int x = 0; x < n; ++x) {  // columns
      for (int y = 0; y < n; ++y) in[size_t(y)] = grid[size_t(y) * n + x];
      forward ? fft.fwd(out, in) : fft.inv(out, in);
      for (int y = 0; y < n; ++y) grid[size_t(y) * n + x] = out[size_t(y)];
    }
  };
  pass(true);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double fx = double(x <= n / 2 ? x : x - n) / n, fy = double(y <= n / 2 ? y : y - n) / n;
      const double k = std::hypot(fx, fy);
      grid[size_t(y) * n + x] *= k > 0 ? std::pow(k, beta / 2) : 0.0;
    }
  pass(false);
  Heightfield h(n, n);
  for (size_t i = 0; i < h.z.size(); ++i) h.z[i] = float(grid[i].real());
  return h;
}

Heightfield crop_of(const Heightfield& h, int x0, int y0, int w, int ht) {
  Heightfield c(w, ht);
  c.georef = h.georef;
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  return c;
}

}  // namespace

TEST(AmplifySpectral, PredictsTheEnergyAboveNyquistOfAPowerLawTerrain) {
  // On a terrain that is a power law at every scale the extrapolation from its 4 x 4 block means is
  // right up to the periodogram's noise (the box filter and its aliases undone; with the box alone
  // it was 1.32 x at beta -3, seed 7, without either ~4 x low).
  // Measured: 0.74-0.93 over these seeds (periodogram noise in one octave, extrapolated 2 octaves).
  for (double beta : {-3.0, -4.0}) {
    double sum = 0;
    for (unsigned seed : {1u, 2u, 3u, 7u}) {
      const Heightfield fine = power_law_field(512, beta, seed);
      const double ratio = predicted_energy_above(block_mean(fine, 4), 4) / energy_above(fine, 4);
      EXPECT_GT(ratio, 0.65) << "beta " << beta << " seed " << seed;
      EXPECT_LT(ratio, 1.35) << "beta " << beta << " seed " << seed;
      sum += ratio;
    }
    EXPECT_NEAR(sum / 4, 1.0, 0.25) << "beta " << beta;
  }
  EXPECT_EQ(predicted_energy_above(block_mean(power_law_field(48, -3.0, 1), 4), 4), -1.0);  // 12 x 12: too small
}

TEST(AmplifySpectral, FirstStepGainMatchesTheCombinedHfEstimate) {
  const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
  const Heightfield ex = crop_of(dem, 100, 300, 256, 192);
  const Heightfield truth = crop_of(dem, 700, 300, 256, 256);
  const Heightfield low = block_mean(truth, 4);  // 64 x 64: the smallest input recalibrated
  LearnOptions l;
  l.max_patches = 3000;
  const Dictionary d = learn_dictionary({ex}, l);
  ASSERT_GT(d.spectral_scale, 0);
  ASSERT_GT(d.rmse_gain, 0);
  AmplifyOptions o;
  const Heightfield out = amplify(low, d, o);
  ASSERT_EQ(out.metadata.count("amplify_hf_calibration"), 1u);
  const double g = std::stod(out.metadata.at("amplify_detail_gain"));
  // The target, computed independently: the held-out estimate (the output at the dictionary's
  // HF-matching gain, over its HF target) and the scaled spectral prediction, geometric mean.
  AmplifyOptions fixed = o;
  fixed.detail_gain = float(d.hf_gain);
  const double held_out = energy_above(amplify(low, d, fixed), 4) / d.hf_target;
  const double spectral = d.spectral_scale * predicted_energy_above(low, 4);
  const double target = std::sqrt(held_out * spectral), hf = energy_above(out, 4);
  if (g < std::min(4.0, d.rmse_gain) - 1e-3) {
    EXPECT_NEAR(hf / target, 1.0, 0.01);
  } else {
    EXPECT_LT(hf, target);  // the folds' RMSE budget binds
  }
  EXPECT_GT(std::fabs(g - d.detail_gain), 1e-3);  // the gain did move
  // The same output as an explicit gain (the metadata's, to 3 decimals).
  fixed.detail_gain = float(g);
  const Heightfield same = amplify(low, d, fixed);
  double worst = 0;
  for (size_t i = 0; i < out.z.size(); ++i) worst = std::max(worst, double(std::fabs(out.z[i] - same.z[i])));
  EXPECT_LT(worst, 0.05);
  // Off: the option, or an explicit gain.
  AmplifyOptions off = o;
  off.hf_from_input = false;
  EXPECT_EQ(amplify(low, d, off).metadata.at("amplify_detail_gain"), fmt::format("{:.3f}", d.detail_gain));
  // A dictionary read from a version 4 file carries the calibration: the same output, bit for bit.
  const test::TempDir tmp;
  const std::string path = tmp.path("d.tdic");
  save_dictionary(d, path);
  const Dictionary e = load_dictionary(path);
  EXPECT_EQ(e.hf_gain, d.hf_gain);
  EXPECT_EQ(e.rmse_gain, d.rmse_gain);
  EXPECT_EQ(e.hf_target, d.hf_target);
  EXPECT_EQ(e.spectral_scale, d.spectral_scale);
  EXPECT_TRUE(e.anisotropy);  // calibrated for the anisotropic detail correlation (flag bit 6)
  const Heightfield loaded = amplify(low, e, o);
  ASSERT_EQ(loaded.size(), out.size());
  EXPECT_EQ(std::memcmp(loaded.z.data(), out.z.data(), sizeof(float) * out.size()), 0);
  EXPECT_EQ(loaded.metadata.at("amplify_hf_calibration"), out.metadata.at("amplify_hf_calibration"));
  EXPECT_EQ(loaded.metadata.at("amplify_detail_gain"), out.metadata.at("amplify_detail_gain"));
  EXPECT_EQ(loaded.metadata.at("amplify_detail_correlation"), out.metadata.at("amplify_detail_correlation"));
  EXPECT_NE(out.metadata.at("amplify_detail_correlation").find("(x "), std::string::npos)
      << out.metadata.at("amplify_detail_correlation");
  // A version 4 file (the same bytes, flag bit 6 not read): its gain was calibrated for one rho,
  // which amplify keeps with it.
  {
    std::string v4;
    {
      std::ifstream f(path, std::ios::binary);
      v4.assign(std::istreambuf_iterator<char>(f), {});
    }
    ASSERT_EQ(v4[4], 5);
    v4[4] = 4;
    uint64_t h4 = 1469598103934665603ull;
    for (size_t i = 0; i + 8 < v4.size(); ++i) h4 = (h4 ^ (unsigned char)v4[i]) * 1099511628211ull;
    for (int i = 0; i < 8; ++i) v4[v4.size() - 8 + i] = char((h4 >> (8 * i)) & 0xff);
    std::ofstream(tmp.path("v4.tdic"), std::ios::binary) << v4;
    const Dictionary e4 = load_dictionary(tmp.path("v4.tdic"));
    EXPECT_FALSE(e4.anisotropy);
    EXPECT_EQ(e4.spectral_scale, d.spectral_scale);
    AmplifyOptions one = o;
    one.detail_anisotropy = false;
    const Heightfield iso = amplify(low, d, one), old4 = amplify(low, e4, o);
    EXPECT_EQ(old4.metadata.at("amplify_detail_correlation").find("(x "), std::string::npos);
    EXPECT_EQ(std::memcmp(old4.z.data(), iso.z.data(), sizeof(float) * iso.size()), 0);
  }
  // A version 3 file (the same bytes without the calibration, flag bit 5 clear): still read, the
  // per-input gain off and said so in the metadata.
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  ASSERT_EQ(bytes[4], 5);
  int32_t flags = 0;
  std::memcpy(&flags, bytes.data() + 24, 4);
  ASSERT_NE(flags & 32, 0);
  flags &= ~32;
  std::memcpy(&bytes[24], &flags, 4);
  bytes[4] = 3;
  const size_t cal_at = 60 + d.description.size() +
                        4 * (size_t(d.patch) * d.patch + size_t(d.low_patch()) * d.low_patch()) * size_t(d.atoms()) +
                        4 * d.low_norm.size();
  ASSERT_EQ(std::memcmp(bytes.data() + cal_at, &d.hf_gain, 8), 0);  // where version 4 keeps it
  bytes.erase(cal_at, 32);
  uint64_t h = 1469598103934665603ull;  // FNV-1a 64 of everything before the hash
  for (size_t i = 0; i + 8 < bytes.size(); ++i) h = (h ^ (unsigned char)bytes[i]) * 1099511628211ull;
  for (int i = 0; i < 8; ++i) bytes[bytes.size() - 8 + i] = char((h >> (8 * i)) & 0xff);
  std::ofstream(tmp.path("v3.tdic"), std::ios::binary) << bytes;
  const Dictionary v3 = load_dictionary(tmp.path("v3.tdic"));
  EXPECT_TRUE(v3.high == d.high);
  EXPECT_EQ(v3.regression.weights.size(), d.regression.weights.size());
  EXPECT_EQ(v3.spectral_scale, -1.0);
  const Heightfield old = amplify(low, v3, o);
  EXPECT_EQ(old.metadata.at("amplify_detail_gain"), fmt::format("{:.3f}", d.detail_gain));
  EXPECT_EQ(old.metadata.at("amplify_hf_calibration").rfind("off:", 0), 0u) << old.metadata.at("amplify_hf_calibration");
  // A corrupt calibration value: a clear error.
  bytes = std::string();
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  const double bad = -2;
  std::memcpy(&bytes[cal_at + 24], &bad, 8);
  h = 1469598103934665603ull;
  for (size_t i = 0; i + 8 < bytes.size(); ++i) h = (h ^ (unsigned char)bytes[i]) * 1099511628211ull;
  for (int i = 0; i < 8; ++i) bytes[bytes.size() - 8 + i] = char((h >> (8 * i)) & 0xff);
  std::ofstream(tmp.path("bad.tdic"), std::ios::binary) << bytes;
  try {
    load_dictionary(tmp.path("bad.tdic"));
    ADD_FAILURE() << "no error";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("corrupt calibration"), std::string::npos) << err.what();
  }
}

TEST(AmplifySpectral, CascadeCalibrationChoosesTheFirstStepGainThroughBothSteps) {
  // x16 of a 23 x 23 input (too small for the per-input gain), exemplar a 256 x 512 crop of the same
  // Front Range DEM: the first step's gain chosen on the folds through both steps (docs/amplify.md,
  // "per-scale calibration") restores more of the truth's HF energy than the first step's own
  // RMSE-capped gain, within the x16 RMSE target, block means exact.
  const Heightfield dem = read_heightfield(test::data_path("dem/frontrange_srtm3_758.asc"));
  const Heightfield ex = crop_of(dem, 0, 0, 256, 512);
  const Heightfield truth = crop_of(dem, 758 - 368, 100, 368, 368);
  const Heightfield low = block_mean(truth, 16);
  LearnOptions l;
  l.max_patches = 3000;
  AmplifyOptions o;
  o.factor = 16;
  const Heightfield out = amplify_from_exemplars(low, {ex}, l, o);
  AmplifyOptions off = o;
  off.cascade_calibration = false;
  const Heightfield old = amplify_from_exemplars(low, {ex}, l, off);
  ASSERT_EQ(out.metadata.count("amplify_hf_calibration"), 1u);
  EXPECT_NE(out.metadata.at("amplify_hf_calibration").find("both steps"), std::string::npos);
  EXPECT_EQ(old.metadata.count("amplify_hf_calibration"), 0u);
  const AmplifyMetrics m = evaluate_amplification(out, truth, low, 16, o.spacing);
  const AmplifyMetrics m0 = evaluate_amplification(old, truth, low, 16, o.spacing);
  const AmplifyMetrics b = evaluate_amplification(bicubic_upsample(low, 16), truth, low, 16, o.spacing);
  std::printf("cascade: HF %.3f RMSE %.3f x bicubic slope %.3f; step gains: HF %.3f RMSE %.3f slope %.3f (%s | %s)\n",
              m.hf_ratio, m.rmse / b.rmse, m.slope_ratio, m0.hf_ratio, m0.rmse / b.rmse, m0.slope_ratio,
              out.metadata.at("amplify_detail_gain").c_str(), old.metadata.at("amplify_detail_gain").c_str());
  // Measured: HF 0.946 against 0.825, RMSE 1.326 against 1.282 x bicubic, slope 1.058 / 1.022 (before the
  // second step's relief scale, issue 16 session 10: HF 0.881 / 0.749, RMSE 1.305 / 1.257, slope 0.929 /
  // 0.885). The folds' budget (1.2) transfers to this small crop with a 0.13 margin; on the eval's whole
  // east half 1.287.
  EXPECT_GT(m.hf_ratio, m0.hf_ratio * 1.1);
  EXPECT_LT(m.rmse / b.rmse, 1.35);
  EXPECT_LT(m.lr_consistency, 1e-2);
  // The second step is the same dictionary's (learned once, ahead of the first step): its gain over the
  // relief scale (which follows the first step's output) is the same.
  auto second_gain = [](const Heightfield& h) {
    const std::string& g = h.metadata.at("amplify_detail_gain");
    const std::string& r = h.metadata.at("amplify_relief_scale");
    return std::stod(g.substr(g.find(',') + 1)) / std::stod(r.substr(r.find("detail x ") + 9));
  };
  EXPECT_NEAR(second_gain(out), second_gain(old), 2e-3);
}
