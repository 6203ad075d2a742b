// SPDX-License-Identifier: Apache-2.0
// Every example edit script in data/examples/ runs with `terracl edit` as a user runs it (each
// script names its own base terrain) and produces a finite terrain of the base's size. The gallery
// examples on flat bases are 1025^2 in metres ("units": "m"); to keep the suite fast they run here
// on a base of half the resolution over the same extent (BASE on the command line overrides the
// script's), which keeps every primitive where it is. scripts/demo.sh runs them at full size.
// What each landform stroke makes is checked by test_landform_strokes.cpp; here every gallery
// example is a short session (at most 12 strokes) that runs and makes relief.

#include "test_helpers.hpp"

#include <terracl/analysis.hpp>
#include <terracl/edit.hpp>
#include <terracl/io.hpp>
#include <terracl/tensor.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <set>

using namespace terracl;

TEST(EditExamples, EveryExampleScriptRuns) {
  namespace fs = std::filesystem;
  test::TempDir tmp;
  int n = 0;
  for (const auto& e : fs::directory_iterator(test::data_path("examples"))) {
    if (e.path().extension() != ".json") continue;
    ++n;
    const std::string name = e.path().stem().string();
    const nlohmann::json script = read_edit_script(e.path().string());
    EXPECT_LE(script.at("operations").size(), 12u) << name << ": a gallery example is a session of at most 12 strokes";
    const std::string base = script.at("base").get<std::string>();
    std::string cli_base;
    int want_w = 0, want_h = 0;
    if (auto flat = parse_flat_spec(base)) {
      want_w = flat->width, want_h = flat->height;
      if (script.value("units", "m") == "m" && flat->width > 600) {
        want_w = (flat->width - 1) / 2 + 1, want_h = (flat->height - 1) / 2 + 1;
        cli_base = fmt::format("flat:{}x{}@{} ", want_w, want_h, 2 * flat->georef.cell_x);
      }
    }
    const auto r = test::run_cli(
        fmt::format("edit -q {}--script {} -o {}", cli_base, e.path().string(), tmp.path(name + ".tif")));
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.out;
    const Heightfield h = read_heightfield(tmp.path(name + ".tif"));
    if (want_w) {
      EXPECT_EQ(h.width, want_w) << name;
      EXPECT_EQ(h.height, want_h) << name;
    }
    float lo = 1e30f, hi = -1e30f;
    for (float v : h.z) {
      ASSERT_TRUE(std::isfinite(v)) << name;
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    EXPECT_GT(hi - lo, 50.0f) << name << ": the edits should make relief";
  }
  EXPECT_GE(n, 7);
}

// The two real-DEM examples are local: a small part of the N44W072 tile changes, all of
// it inside the solved window the report names, and the rest is the tile bit for bit.
TEST(EditExamples, RealDemExamplesAreLocal) {
  test::TempDir tmp;
  const Heightfield base = read_heightfield(test::data_path("dem/N44W072.hgt"));
  for (const std::string name : {"n44_ridge", "n44_dam"}) {
    const std::string script = test::data_path("examples/" + name + ".json");
    const auto r = test::run_cli(fmt::format("edit -q --script {} -o {} --report {}", script, tmp.path(name + ".tif"),
                                             tmp.path(name + ".json")));
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.out;
    const Heightfield h = read_heightfield(tmp.path(name + ".tif"));
    const nlohmann::json rep = read_edit_script(tmp.path(name + ".json"));
    ASSERT_EQ(rep.at("solve"), "local") << name;
    const auto& w = rep.at("locality").at("window");
    const int x0 = w[0], y0 = w[1], x1 = x0 + int(w[2]), y1 = y0 + int(w[3]);
    ASSERT_EQ(h.size(), base.size());
    size_t changed = 0, outside = 0;
    for (int y = 0; y < h.height; ++y)
      for (int x = 0; x < h.width; ++x)
        if (h.at(x, y) != base.at(x, y)) {
          ++changed;
          outside += x < x0 || x >= x1 || y < y0 || y >= y1;
        }
    EXPECT_GT(changed, name == "n44_dam" ? 200u : 1000u) << name;  // the dam is a narrow wall; its lake leaves the terrain
    EXPECT_LT(changed, base.size() / 20) << name << ": under 5 % of the tile";
    EXPECT_EQ(outside, 0u) << name;
  }
}

