// Every example edit script in data/examples/ runs with `terracl edit` as a user runs it (each
// script names its own base terrain) and produces a finite terrain of the base's size.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>

using namespace terracl;

TEST(EditExamples, EveryExampleScriptRuns) {
  namespace fs = std::filesystem;
  test::TempDir tmp;
  int n = 0;
  for (const auto& e : fs::directory_iterator(test::data_path("examples"))) {
    if (e.path().extension() != ".json") continue;
    ++n;
    const std::string name = e.path().stem().string();
    const auto r = test::run_cli(fmt::format("edit -q --script {} -o {}", e.path().string(), tmp.path(name + ".tif")));
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.out;
    const Heightfield h = read_heightfield(tmp.path(name + ".tif"));
    const nlohmann::json script = read_edit_script(e.path().string());
    const std::string base = script.at("base").get<std::string>();
    if (auto flat = parse_flat_spec(base)) {
      EXPECT_EQ(h.width, flat->width) << name;
      EXPECT_EQ(h.height, flat->height) << name;
    }
    float lo = 1e30f, hi = -1e30f;
    for (float v : h.z) {
      ASSERT_TRUE(std::isfinite(v)) << name;
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    EXPECT_GT(hi - lo, 50.0f) << name << ": the edits should make relief";
  }
  EXPECT_GE(n, 6);
}
