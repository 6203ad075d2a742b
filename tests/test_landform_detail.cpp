// SPDX-License-Identifier: Apache-2.0
// Real detail on landform strokes (docs/authoring.md, "Detail and styles"): the relief finer than
// 4 cells in a stroke's footprint comes from a sparse dictionary (a bundled style, the base DEM's
// own texture, or a painted style region); nothing outside the footprint moves, the footprint's
// volume is kept, painted styles govern the strokes inside them, and retexturing stays in its region.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/io.hpp>

#include <algorithm>
#include <cmath>

using namespace terracl;
using nlohmann::json;

namespace {

struct Result {
  Heightfield h;
  json log;
};

Result run(const Heightfield& base, const std::vector<json>& ops, EditOptions o = {}) {
  EditSession s(test::device(), base, o);
  json arr = json::array();
  for (const auto& op : ops) arr.push_back(op);
  s.apply({{"units", "cells"}, {"operations", arr}});
  return {s.height(), s.log()};
}

const json kRange = {{"op", "mountain_range"}, {"points", {{40, 110}, {100, 90}, {160, 105}}}, {"seed", 5}};

json with(json op, const std::string& key, const json& v) {
  op[key] = v;
  return op;
}

}  // namespace

TEST(LandformDetail, DictionaryDetailStaysInTheFootprintAndKeepsItsVolume) {
  const Heightfield base = *parse_flat_spec("flat:200x200@30+100");
  const Result real = run(base, {kRange});
  const Result proc = run(base, {with(kRange, "detail", "procedural")});
  ASSERT_EQ(real.log[0]["detail"], "dictionary") << real.log.dump();
  ASSERT_EQ(proc.log[0]["detail"], "procedural");
  double inside = 0, outside = 0, vol_real = 0, vol_proc = 0;
  size_t cells = 0;
  for (size_t i = 0; i < base.z.size(); ++i) {
    const double cp = proc.h.z[i] - base.z[i], cr = real.h.z[i] - base.z[i];
    ASSERT_TRUE(std::isfinite(cr));
    EXPECT_GE(cr, -0.05) << "a raising landform lowered cell " << i;
    if (std::abs(cp) < 1e-3) {
      outside = std::max(outside, std::abs(cr));
    } else {
      inside = std::max(inside, std::abs(cr - cp));
      vol_real += cr, vol_proc += cp, ++cells;
    }
  }
  EXPECT_LT(outside, 0.05) << "the detail moved a cell outside the landform's footprint";
  EXPECT_GT(inside, 2.0) << "the dictionary's detail should differ from the procedural one";
  // Block means are kept where the detail is fully blended in; the footprint's volume stays.
  EXPECT_NEAR(vol_real / double(cells), vol_proc / double(cells), 0.03 * vol_proc / double(cells));
  // Deterministic: the same stroke gives the same bits.
  EXPECT_EQ(run(base, {kRange}).h.z, real.h.z);
}

TEST(LandformDetail, LocalStyleIsTheBaseDemsOwnAndNeedsOne) {
  const Heightfield dem = test::n44_window(300, 600, 200);
  const Result local = run(dem, {kRange});
  const Result alpine = run(dem, {with(kRange, "detail", "alpine")});
  EXPECT_EQ(local.log[0]["detail"], "dictionary");
  EXPECT_NE(local.h.z, alpine.h.z) << "auto on a real DEM is its own texture, not the alpine style";
  EXPECT_EQ(run(dem, {with(kRange, "detail", "local")}).h.z, local.h.z);
  // A level base has no texture of its own: "local" keeps the procedural detail.
  const Result flat = run(*parse_flat_spec("flat:200x200@30+100"), {with(kRange, "detail", "local")});
  EXPECT_EQ(flat.log[0]["detail"], "procedural");
}

TEST(LandformDetail, PaintedStyleGovernsTheStrokesInsideIt) {
  const Heightfield base = *parse_flat_spec("flat:200x200@30+100");
  const json paint = {{"op", "style"}, {"style", "eroded_hills"}, {"center", {100, 100}}, {"radius", 150}, {"retexture", false}};
  const Result painted = run(base, {paint, kRange});
  const Result named = run(base, {with(kRange, "detail", "eroded_hills")});
  const Result alpine = run(base, {kRange});
  // The painted region's support widens the local solve's window: equal within the solver's rounding.
  double same = 0, other = 0;
  for (size_t i = 0; i < base.z.size(); ++i)
    same = std::max(same, double(std::abs(painted.h.z[i] - named.h.z[i]))),
    other = std::max(other, double(std::abs(painted.h.z[i] - alpine.h.z[i])));
  EXPECT_GT(other, 1.0);
  EXPECT_LT(same, 0.05 * other) << "a stroke inside a painted region takes its style (" << same << " m from the named "
                                << "style's, " << other << " m from alpine's)";
}

TEST(LandformDetail, RetextureStaysInItsRegionAndKeepsTheGroundsLevel) {
  const Heightfield dem = test::n44_window(300, 600, 160);
  const double cx = 80, cy = 80, r = 30, falloff = 8;
  const Result t = run(dem, {json{{"op", "style"}, {"style", "alpine"}, {"center", {cx, cy}}, {"radius", r}, {"falloff", falloff}}});
  double far = 0, near = 0, mean = 0;
  size_t n = 0;
  for (int y = 0; y < dem.height; ++y)
    for (int x = 0; x < dem.width; ++x) {
      const double d = std::hypot(x - cx, y - cy), c = t.h.at(x, y) - dem.at(x, y);
      ASSERT_TRUE(std::isfinite(c));
      if (d > r + falloff + 2) far = std::max(far, std::abs(c));
      if (d < r) near = std::max(near, std::abs(c)), mean += c, ++n;
    }
  EXPECT_LT(far, 0.05) << "retexturing moved a cell outside its region";
  EXPECT_GT(near, 1.0) << "retexturing should change the relief inside its region";
  EXPECT_LT(std::abs(mean / double(n)), 1.0) << "the block means (the ground's level) are kept";
}

TEST(LandformDetail, PreviewsAndTheProceduralChoiceSkipTheDictionary) {
  const Heightfield base = *parse_flat_spec("flat:200x200@30+100");
  EditOptions o;
  o.landform_detail = false;
  EXPECT_EQ(run(base, {kRange}, o).log[0]["detail"], "procedural");
}

TEST(LandformDetail, UnknownStylesAreRefusedWithTheirPath) {
  const Heightfield base = *parse_flat_spec("flat:64x64@30+100");
  EditSession s(test::device(), base);
  try {
    s.apply({{"units", "cells"}, {"operations", {with(kRange, "detail", "marble")}}});
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/operations/0/detail"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("alpine"), std::string::npos) << e.what();
  }
  try {
    s.apply({{"units", "cells"}, {"operations", {{{"op", "style"}, {"style", "chalk"}, {"center", {30, 30}}, {"radius", 10}}}}});
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/operations/0/style"), std::string::npos) << e.what();
  }
}
