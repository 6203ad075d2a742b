// SPDX-License-Identifier: Apache-2.0
// The "lake" edit operation: water fills exactly the cells below its level connected to its seed
// (against a brute-force search), spills at the saddle, leaves the other basin dry and the
// terrain's bits alone, follows the script's final terrain, and names the JSON path of a bad seed.
#include "edit_helpers.hpp"
#include "lake_terrain.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

using namespace terracl;
using json = nlohmann::json;

namespace {

json lake(double x, double y, json extra = json::object()) {
  json op = {{"op", "lake"}, {"seed", {x, y}}};
  for (auto it = extra.begin(); it != extra.end(); ++it) op[it.key()] = it.value();
  return op;
}
json lake(const double seed[2], json extra = json::object()) { return lake(seed[0], seed[1], std::move(extra)); }

// Cells where two depth layers differ (bits; the lake's depths are level - terrain, computed the
// same way on both sides).
size_t differences(const std::vector<float>& a, const std::vector<float>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

std::vector<float> water_of(const Heightfield& base, const std::vector<json>& ops, json* lakes = nullptr) {
  EditSession s(test::device(), base);
  s.apply({{"operations", json(ops)}});
  const std::optional<Heightfield> w = s.water();
  EXPECT_TRUE(w.has_value());
  if (lakes) *lakes = s.lakes();
  return w ? w->z : std::vector<float>();
}

}  // namespace

TEST(EditLake, FillsExactlyTheConnectedCellsBelowTheSpillLevel) {
  const Heightfield base = test::two_basins();
  EditSession s(test::device(), base);
  s.apply({{"operations", {lake(test::kSeedA)}}});
  const std::optional<Heightfield> w = s.water();
  ASSERT_TRUE(w.has_value());
  ASSERT_EQ(w->width, base.width);
  const json lakes = s.lakes();
  ASSERT_EQ(lakes.size(), 1u);
  // The spill level is the saddle's elevation, and the water leaves by the saddle.
  EXPECT_EQ(lakes[0]["level_m"].get<double>(), 100.0) << lakes.dump();
  EXPECT_EQ(lakes[0]["spill_cell"], json({23, 12}));
  EXPECT_EQ(lakes[0]["pit_cell"], json({9, 11}));  // the seed is on the floor's slope: the water runs down first
  EXPECT_FALSE(lakes[0]["spills_off_map"].get<bool>());
  // Exactly the brute force's cells and depths: the island and the ringed pit stay dry, and so
  // does basin B (below 100 m too, but beyond the saddle).
  const std::vector<float> want = test::brute_force_lake(base, 11, 11, 100.0);
  EXPECT_EQ(differences(w->z, want), 0u);
  size_t wet = 0;
  double sum = 0, deepest = 0;
  for (int y = 0; y < base.height; ++y)
    for (int x = 0; x < base.width; ++x) {
      const float d = w->at(x, y);
      ASSERT_TRUE(std::isfinite(d) && d >= 0) << x << "," << y;
      if (x > 24 || (x >= 6 && x <= 7 && y >= 6 && y <= 7) || (x >= 16 && x <= 18 && y >= 17 && y <= 19))
        EXPECT_EQ(d, 0.f) << "dry cell " << x << "," << y;
      wet += d > 0, sum += d, deepest = std::max(deepest, double(d));
    }
  EXPECT_EQ(wet, 22u * 22u - 4u - 25u) << "basin A less the island and the pit's ring and floor";
  EXPECT_EQ(lakes[0]["cells"].get<size_t>(), wet);
  // Volume = sum of depths x cell area.
  EXPECT_NEAR(lakes[0]["volume_m3"].get<double>(), sum * 100.0, 1e-6 * sum * 100.0);
  EXPECT_NEAR(lakes[0]["max_depth_m"].get<double>(), deepest, 1e-4);
  EXPECT_EQ(lakes[0]["area_m2"].get<double>(), double(wet) * 100.0);
  // The terrain is untouched, bit for bit.
  EXPECT_EQ(test::bit_differences(s.height(), base), 0u);
  const json report = s.report();
  EXPECT_EQ(report["lakes"], lakes);
  EXPECT_EQ(report["water"]["cells"].get<size_t>(), wet);
  EXPECT_EQ(report["operations"][0]["level_m"].get<double>(), 100.0);
}

TEST(EditLake, BasinBSpillsAtTheSameSaddleAndCellUnitsWork) {
  const Heightfield base = test::two_basins();
  json lakes;
  const std::vector<float> w = water_of(base, {lake(test::kSeedB)}, &lakes);
  EXPECT_EQ(lakes[0]["level_m"].get<double>(), 100.0);
  EXPECT_EQ(differences(w, test::brute_force_lake(base, 35, 11, 100.0)), 0u);
  for (int y = 0; y < base.height; ++y)
    for (int x = 0; x < 24; ++x) EXPECT_EQ(w[size_t(y) * base.width + x], 0.f) << "basin A stays dry";
  // "units": "cells": the same seed as a cell.
  EditSession s(test::device(), base);
  s.apply({{"units", "cells"}, {"operations", {{{"op", "lake"}, {"seed", {35, 11}}}}}});
  EXPECT_EQ(s.water()->z, w);
}

TEST(EditLake, AnExplicitLevelOrDepthFillsTheConnectedCellsBelowIt) {
  const Heightfield base = test::two_basins();
  const double seed_z = base.at(11, 11);
  struct Case {
    json extra;
    double level;
  };
  const std::vector<Case> cases = {
      {{{"level", 60}}, 60.0},
      {{{"level", "0.095 km"}}, 95.0},
      {{{"level", 130}}, 130.0},  // over the saddle: both basins, the island and the pit fill
      {{{"level", "spill"}}, 100.0},
      {{{"depth", 15}}, seed_z + 15.0},
  };
  for (const Case& c : cases) {
    json lakes;
    const std::vector<float> w = water_of(base, {lake(test::kSeedA, c.extra)}, &lakes);
    EXPECT_EQ(lakes[0]["level_m"].get<double>(), c.level) << c.extra.dump();
    const std::vector<float> want = test::brute_force_lake(base, 11, 11, c.level);
    EXPECT_EQ(differences(w, want), 0u) << c.extra.dump();
    EXPECT_EQ(lakes[0]["cells"].get<size_t>(), size_t(std::count_if(want.begin(), want.end(), [](float d) { return d > 0; })));
  }
  const std::vector<float> over = water_of(base, {lake(test::kSeedA, {{"level", 130}})});
  EXPECT_GT(over[size_t(11) * base.width + 35], 0.f) << "above the saddle the water reaches basin B";
  EXPECT_GT(over[size_t(18) * base.width + 17], 0.f) << "and the pit";
}

TEST(EditLake, LakesKeepTheHighestWaterSurface) {
  const Heightfield base = test::two_basins();
  const std::vector<float> w =
      water_of(base, {lake(test::kSeedA, {{"level", 60}}), lake(test::kSeedA), lake(test::kSeedB, {{"level", 50}})});
  const std::vector<float> a60 = test::brute_force_lake(base, 11, 11, 60), a = test::brute_force_lake(base, 11, 11, 100),
                           b50 = test::brute_force_lake(base, 35, 11, 50);
  for (size_t i = 0; i < w.size(); ++i) EXPECT_EQ(w[i], std::max({a60[i], a[i], b50[i]})) << i;
}

TEST(EditLake, TheWaterIsFilledOnTheFinalTerrain) {
  // A lake at 170 m fills both basins over the 150 m wall; a dam after it (a crest at 180 m down
  // column 16) holds the water west of it: the lake is filled on the dammed terrain.
  const Heightfield base = test::two_basins();
  const json dam = {{"op", "crest"}, {"points", {{160, -50}, {160, 300}}}, {"elevation", 180}, {"radius", 20}};
  const json reservoir = lake(50, 110, {{"level", 170}});
  EXPECT_GT(water_of(base, {reservoir})[size_t(11) * base.width + 35], 0.f) << "without the dam basin B is wet";
  EditSession s(test::device(), base);
  s.apply({{"operations", {reservoir, dam}}});
  const std::optional<Heightfield> w = s.water();
  ASSERT_TRUE(w.has_value());
  const Heightfield& h = s.height();
  EXPECT_GT(test::bit_differences(h, base), 0u) << "the dam changed the terrain";
  EXPECT_EQ(differences(w->z, test::brute_force_lake(h, 5, 11, 170.0)), 0u);
  EXPECT_GT(s.lakes()[0]["cells"].get<size_t>(), 50u) << s.lakes().dump();
  for (int y = 0; y < h.height; ++y)
    for (int x = 16; x < h.width; ++x) EXPECT_EQ(w->at(x, y), 0.f) << "beyond the dam " << x << "," << y;
  // The lake changes nothing: the same script without it has the same terrain, bit for bit.
  EditSession plain(test::device(), base);
  plain.apply({{"operations", {dam}}});
  EXPECT_EQ(test::bit_differences(plain.height(), h), 0u);
  EXPECT_FALSE(plain.water().has_value());
  EXPECT_FALSE(plain.report().contains("lakes"));
}

TEST(EditLake, AnEmptyLakeIsAWarningNamingTheSeed) {
  const Heightfield base = test::two_basins();
  // On the wall (150 m): the water runs down into basin A, whose spill level (100 m) is below it.
  EditSession s(test::device(), base);
  s.apply({{"operations", {lake(230, 50), lake(test::kSeedA, {{"level", 30}})}}});
  const std::optional<Heightfield> w = s.water();
  ASSERT_TRUE(w.has_value());
  for (float d : w->z) ASSERT_EQ(d, 0.f);
  const std::vector<std::string> warnings = s.warnings();
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("/operations/0/seed: the seed cell (23, 5), at 150 m, is not below the spill level 100 m of "
                             "the depression it drains into (lowest cell (9, 11))"),
            std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[1].find("/operations/1/seed: the terrain at the seed cell (11, 11)"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[1].find("is not below the lake's level 30 m"), std::string::npos) << warnings[1];
  EXPECT_EQ(s.lakes()[0]["cells"], 0);
  // On a plane tilted towards the west edge nothing is held: the water drains off the map.
  Heightfield plane(32, 16);
  plane.georef.cell_x = plane.georef.cell_y = 10;
  for (int y = 0; y < plane.height; ++y)
    for (int x = 0; x < plane.width; ++x) plane.at(x, y) = float(x);
  EditSession p(test::device(), plane);
  p.apply({{"operations", {lake(150, 80)}}});
  const std::optional<Heightfield> pw = p.water();
  ASSERT_TRUE(pw.has_value());
  for (float d : pw->z) ASSERT_EQ(d, 0.f);
  ASSERT_EQ(p.warnings().size(), 1u);
  EXPECT_NE(p.warnings()[0].find("/operations/0/seed: the seed cell (15, 8) is not in a closed depression (the water there "
                                 "drains away off the map)"),
            std::string::npos)
      << p.warnings()[0];
  EXPECT_EQ(p.lakes()[0]["pit_cell"], json({0, 8}));
}

TEST(EditLake, BadParametersNameTheJsonPath) {
  const Heightfield base = test::two_basins();
  auto err = [&](const json& op) { return test::edit_op_error(base, op); };
  EXPECT_NE(err(lake(-100, 50)).find("/operations/0/seed: expected a point on the 48x24 grid"),
            std::string::npos)
      << err(lake(-100, 50));
  EXPECT_NE(err(lake(100, 236)).find("/operations/0/seed"), std::string::npos);
  EXPECT_NE(err({{"op", "lake"}}).find("/operations/0/seed: missing"), std::string::npos);
  EXPECT_NE(err(lake(test::kSeedA, {{"level", 90}, {"depth", 3}})).find("/operations/0/depth: give either"), std::string::npos);
  EXPECT_NE(err(lake(test::kSeedA, {{"depth", -3}})).find("/operations/0/depth: expected a depth > 0 m"), std::string::npos);
  EXPECT_NE(err(lake(test::kSeedA, {{"level", "high"}})).find("/operations/0/level: expected \"spill\" or an elevation"),
            std::string::npos);
  EXPECT_NE(err(lake(test::kSeedA, {{"level", true}})).find("/operations/0/level: expected \"spill\""), std::string::npos);
  EXPECT_NE(err(lake(test::kSeedA, {{"levle", 90}})).find("/operations/0/levle: unknown parameter"), std::string::npos);
  // The last cell's far half is still on the grid.
  EXPECT_EQ(err(lake(474, 234)), "");
}

TEST(EditLake, CliWritesTheWaterLayerReportAndTintedPreview) {
  test::TempDir tmp;
  Heightfield base = test::two_basins();
  write_heightfield(base, tmp.path("base.tif"));
  write_text_file_atomic(tmp.path("s.json"), json{{"operations", {lake(test::kSeedA)}}}.dump());
  const auto r = test::run_cli(fmt::format("edit {} --script {} -o {} --water {} --report {} --preview {}", tmp.path("base.tif"),
                                           tmp.path("s.json"), tmp.path("o.tif"), tmp.path("w.tif"), tmp.path("r.json"),
                                           tmp.path("p.png")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield w = read_heightfield(tmp.path("w.tif"));
  EXPECT_EQ(differences(w.z, test::brute_force_lake(base, 11, 11, 100.0)), 0u);
  EXPECT_EQ(w.georef.geotransform, read_heightfield(tmp.path("o.tif")).georef.geotransform);
  std::ifstream rf(tmp.path("r.json"));
  const json rep = json::parse(rf);
  EXPECT_EQ(rep["lakes"][0]["level_m"].get<double>(), 100.0);
  EXPECT_TRUE(std::filesystem::exists(tmp.path("p.png")));
  // Without a lake operation --water writes zeros and says why.
  write_text_file_atomic(tmp.path("n.json"), R"({"operations": []})");
  const auto n = test::run_cli(fmt::format("edit {} --script {} -o {} --water {}", tmp.path("base.tif"), tmp.path("n.json"),
                                           tmp.path("o2.tif"), tmp.path("w2.tif")));
  ASSERT_EQ(n.exit_code, 0) << n.out;
  EXPECT_NE(n.out.find("no lake operation"), std::string::npos) << n.out;
  for (float d : read_heightfield(tmp.path("w2.tif")).z) ASSERT_EQ(d, 0.f);
}

TEST(EditLake, PreviewTintIsBlueOverWaterOnly) {
  const Heightfield base = test::two_basins();
  const std::vector<float> depth = test::brute_force_lake(base, 11, 11, 100.0);
  Heightfield w(base.width, base.height);
  w.z = depth;
  render::Options ro;
  ro.mode = render::Mode::ShadedRelief;
  ro.ramp = render::ColorRamp::from_spec("grey");
  render::Image img = render::render(base, ro);
  const render::Image before = img;
  render::tint_water(img, w);
  ASSERT_GE(img.channels, 3);
  for (size_t i = 0; i < depth.size(); ++i) {
    const uint8_t* p = &img.pixels[i * img.channels];
    if (depth[i] > 0)
      EXPECT_GT(int(p[2]), int(p[0]) + 30) << "water is blue at " << i;
    else
      EXPECT_EQ(p[0], before.pixels[i * before.channels]) << "dry ground keeps its grey at " << i;
  }
}
