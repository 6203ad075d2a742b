// SPDX-License-Identifier: Apache-2.0
// The two edit-script additions the studio relies on: the "erode" operation and "enabled": false.
#include <cmath>
#include <cstdio>
#include <terracl/edit.hpp>
#include <terracl/error.hpp>

#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;

Heightfield run_script(const json& script, size_t* hard = nullptr) {
  EditSession s(test::device(), *parse_flat_spec("flat:65x65@30"));
  s.apply(script);
  Heightfield h = s.height();
  if (hard) *hard = s.hard_cells();
  return h;
}

const json kRange = {{"op", "mountain_range"}, {"points", {{300, 900, 400}, {1600, 1000, 500}}}, {"radius", 600}};
const json kCrest = {{"op", "crest"}, {"points", {{200, 300}, {1700, 300}}}, {"elevation", 250}, {"radius", 300}};

TEST(EditErode, ErodesTheTerrainAndKeepsHardConstraintsExact) {
  size_t hard = 0;
  const Heightfield before = run_script({{"operations", {kRange, kCrest}}});
  const Heightfield after =
      run_script({{"operations", {kRange, kCrest, {{"op", "erode"}, {"steps", 40}, {"rain", 0.02}}}}}, &hard);
  ASSERT_GT(hard, 0u);
  double change = 0;
  size_t at_crest = 0;
  for (size_t i = 0; i < after.z.size(); ++i) {
    ASSERT_TRUE(std::isfinite(after.z[i]));
    change = std::max(change, double(std::fabs(after.z[i] - before.z[i])));
    if (before.z[i] == 250.f) {  // a crest cell: hard constraints stay exact through the erosion
      EXPECT_EQ(after.z[i], 250.f);
      ++at_crest;
    }
  }
  EXPECT_GT(at_crest, 10u);
  EXPECT_GT(change, 0.01) << "40 erosion steps left the terrain unchanged";
  // Deterministic: the same script gives the same bits (what makes studio sessions replay).
  EXPECT_EQ(after.z,
            run_script({{"operations", {kRange, kCrest, {{"op", "erode"}, {"steps", 40}, {"rain", 0.02}}}}}).z);
}

// The operation settles the suspended sediment like the erode stage: without settling
// the load in suspension at the end is lost and the mean elevation drops by it.
TEST(EditErode, SettlesTheSuspendedSedimentLikeTheStage) {
  const json erode = {{"op", "erode"}, {"steps", 40}, {"rain", 0.02}};
  json unsettled = erode;
  unsettled["settle"] = false;
  const Heightfield before = run_script({{"operations", {kRange}}});
  const Heightfield settled_h = run_script({{"operations", {kRange, erode}}});
  const Heightfield lost_h = run_script({{"operations", {kRange, unsettled}}});
  auto mean = [](const Heightfield& h) {
    double m = 0;
    for (float z : h.z) m += z;
    return m / double(h.z.size());
  };
  const double m0 = mean(before), ms = mean(settled_h), ml = mean(lost_h);
  std::printf("erode op: mean elevation %.4f -> %.4f m settled, %.4f m without settling\n", m0, ms, ml);
  EXPECT_GT(ms - ml, 1e-3) << "settling must return the suspended load to the bed";
  EXPECT_LE(ms, m0 + 1e-3) << "settling adds no material (the open border may drain some)";
  EXPECT_THROW(run_script({{"operations", {kRange, {{"op", "erode"}, {"steps", 4}, {"settle", "yes"}}}}}), Error);
}

// "diffusion" and "channel_diffusion" reach the erosion (the gallery's range lowers both so that the
// sheet flow down its steep flanks does not plane the gullies it cuts): the creep smooths, so with
// both off the eroded surface keeps more curvature than with the defaults (2 m^2/s and 1).
// RMS of the 5-point Laplacian (m) over the interior of the 65 x 65 test grid: how crinkled it is.
double laplacian_rms(const Heightfield& h) {
  double s = 0;
  for (int y = 1; y < 64; ++y)
    for (int x = 1; x < 64; ++x) {
      const double l = h.at(x - 1, y) + h.at(x + 1, y) + h.at(x, y - 1) + h.at(x, y + 1) - 4.0 * h.at(x, y);
      s += l * l;
    }
  return std::sqrt(s / (63.0 * 63.0));
}

TEST(EditErode, DiffusionOptionsReachTheErosion) {
  const json noise = {{"op", "noise"}, {"amplitude", 30}, {"wavelength", 150}, {"octaves", 3}};
  // Creep everywhere, not only into the cuts the water made (the default), so that it smooths the
  // noise, and strong enough to show in 40 steps.
  const json erode = {{"op", "erode"}, {"steps", 40}, {"rain", 0.02}, {"creep_into_cuts", false}, {"diffusion", 6}};
  json bare = erode;
  bare["diffusion"] = 0;
  bare["channel_diffusion"] = 0;
  const auto roughness = laplacian_rms;
  const double with_creep = roughness(run_script({{"operations", {kRange, noise, erode}}}));
  const double without = roughness(run_script({{"operations", {kRange, noise, bare}}}));
  std::printf("erode op: RMS Laplacian %.4f m with creep (6 m^2/s), %.4f m without\n", with_creep, without);
  EXPECT_GT(without, 1.05 * with_creep);
  json bad = erode;
  bad["channel_diffusion"] = -1;
  EXPECT_THROW(run_script({{"operations", {kRange, bad}}}), Error);
}

// Presets are looks in physical units: old hills creep more than young alpine relief (a smoother
// surface), and a key given with a preset overrides it.
TEST(EditErode, PresetsGiveTheirLooksAndKeysOverrideThem) {
  const json noise = {{"op", "noise"}, {"amplitude", 30}, {"wavelength", 150}, {"octaves", 3}};
  const auto lap = laplacian_rms;
  auto with = [&](json erode) { return run_script({{"operations", {kRange, noise, erode}}}); };
  const Heightfield alpine = with({{"op", "erode"}, {"steps", 40}, {"preset", "young_alpine"}});
  const Heightfield hills = with({{"op", "erode"}, {"steps", 40}, {"preset", "old_hills"}});
  for (float z : hills.z) ASSERT_TRUE(std::isfinite(z));
  EXPECT_GT(lap(alpine), 1.05 * lap(hills)) << "old hills are smoother than young alpine relief";
  // young_alpine with old_hills' creep and rates is old_hills' erosion.
  const Heightfield overridden = with({{"op", "erode"}, {"steps", 40}, {"preset", "young_alpine"}, {"rain", 0.002},
                                      {"dissolve", 0.005}, {"deposit", 0.004}, {"diffusion", 6}, {"channel_diffusion", 2},
                                      {"thermal_rate", 0.03}, {"talus", 25}});
  EXPECT_EQ(overridden.z, hills.z);
  EXPECT_THROW(with({{"op", "erode"}, {"steps", 4}, {"preset", "lunar"}}), Error);
}

TEST(EditErode, ABrushRegionLeavesTheRestAlone) {
  const Heightfield before = run_script({{"operations", {kRange}}});
  const json brush = {{"op", "erode"},        {"steps", 40},   {"rain", 0.02},
                      {"center", {600, 950}}, {"radius", 300}, {"falloff", 100}};
  const Heightfield after = run_script({{"operations", {kRange, brush}}});
  double inside = 0, outside = 0;
  for (int y = 0; y < 65; ++y)
    for (int x = 0; x < 65; ++x) {
      const double d = std::hypot(x * 30.0 - 600, y * 30.0 - 950), c = std::fabs(after.at(x, y) - before.at(x, y));
      if (d < 300) inside = std::max(inside, c);
      if (d > 700) outside = std::max(outside, c);
    }
  EXPECT_GT(inside, 0.01);
  // Outside the brush only the re-solve's round-off (and the mean) moves.
  EXPECT_LT(outside, 0.1 * inside);
}

TEST(EditScript, DisabledOperationsAreValidatedButNotRun) {
  json noise = {{"op", "noise"}, {"amplitude", 20}, {"wavelength", 300}};
  json hidden = kCrest;
  hidden["enabled"] = false;
  // A hidden crest changes nothing, and the noise after it keeps its script index (its default seed):
  // equal to the noise alone with that seed given explicitly.
  const Heightfield with_hidden = run_script({{"operations", {hidden, noise}}});
  json noise_seeded = noise;
  noise_seeded["seed"] = int((1u * 1000003u + 1u) % 1000000007u);  // the default seed of index 1
  const Heightfield plain = run_script({{"operations", {noise_seeded}}});
  EXPECT_EQ(with_hidden.z, plain.z);
  hidden["enabled"] = "no";
  EXPECT_THROW(run_script({{"operations", {hidden}}}), Error);
  json bad_hidden = {{"op", "crest"}, {"radius", -1}, {"enabled", false}};
  EXPECT_THROW(run_script({{"operations", {bad_hidden}}}), Error);
}

}  // namespace
}  // namespace terracl
