// SPDX-License-Identifier: Apache-2.0
// Every edit operation rejects bad parameters with an error naming the JSON path, before anything
// runs; the CLI reports them and leaves no output behind.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <filesystem>
#include <set>

using namespace terracl;
using json = nlohmann::json;

namespace {

// Returns the error message of validating `ops` on a 32x32 grid of 10 m cells ("" when valid).
std::string validate(const json& script) {
  static EditSession* s = nullptr;
  static Heightfield base = *parse_flat_spec("flat:32x32@10");
  if (!s) s = new EditSession(test::device(), base);  // lives for the test binary
  try {
    s->validate(script);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string validate_op(const json& op) { return validate(json{{"operations", json::array({op})}}); }

struct Case {
  json op;
  std::string path;  ///< expected in the message
};

}  // namespace

TEST(EditParams, EveryOperationRejectsBadParameters) {
  const std::string dem = test::data_path("crops/frontrange_64.asc");
  const std::vector<Case> cases = {
      {{{"op", "scale_slopes"}, {"center", {5, 5}}, {"radius", 3}, {"factor", -2}}, "/operations/0/factor"},
      {{{"op", "scale_slopes"}, {"factor", 2}}, "/operations/0: needs a region"},
      {{{"op", "noise"}, {"amplitude", 5}, {"wavelength", 0}}, "/operations/0/wavelength"},
      {{{"op", "noise"}, {"amplitude", 5}, {"wavelength", 10}, {"type", "simplex"}}, "/operations/0/type"},
      {{{"op", "noise"}, {"amplitude", 5}, {"wavelength", 10}, {"octaves", 40}}, "/operations/0/octaves"},
      {{{"op", "freeze"}, {"center", {5, 5}}, {"radius", -1}}, "/operations/0/radius"},
      {{{"op", "freeze"}, {"polygon", {{1, 1}, {2, 2}}}}, "/operations/0/polygon"},
      {{{"op", "tensor"}, {"primitives", json::array()}}, "/operations/0/primitives"},
      {{{"op", "tensor"}, {"primitives", {{{"shape", "blob"}, {"radius", 5}}}}}, "/operations/0/primitives/0/shape"},
      {{{"op", "tensor"}, {"primitives", {{{"shape", "point"}, {"center", {1, 1}}, {"radius", 5}, {"strength", 3}}}}},
       "/operations/0/primitives/0/strength"},
      {{{"op", "crest"}, {"points", {{1, 1}}}, {"elevation", 5}, {"radius", 5}}, "/operations/0/points"},
      {{{"op", "crest"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}, {"height", -5}}, "/operations/0/height"},
      {{{"op", "crest"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}, {"roughness", 1.5}}, "/operations/0/roughness"},
      {{{"op", "cliff"}, {"points", {{1, 1}, {9, 9}}}, {"drop", 5}, {"height", 5}}, "/operations/0/drop"},
      {{{"op", "river"}, {"points", {{1, 1}, {9, 9}}}, {"depth", 0}}, "/operations/0/depth"},
      {{{"op", "crest"}, {"points", {{1, 1, 3}, {9, 9}}}, {"radius", 5}}, "/operations/0/points"},
      {{{"op", "cliff"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", 5}, {"radius", 5}, {"height", -3}}, "/operations/0/height"},
      {{{"op", "cliff"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", 5}, {"radius", 5}, {"height", 3}, {"side", "up"}}, "/operations/0/side"},
      {{{"op", "river"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", 5}, {"radius", 0}}, "/operations/0/radius"},
      {{{"op", "river"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", 5}, {"radius", 4}, {"bank_height", -1}}, "/operations/0/bank_height"},
      {{{"op", "free_crest"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}}, "/operations/0/height"},
      {{{"op", "fault"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}, {"throw", "ten metres"}}, "/operations/0/throw"},
      {{{"op", "ravine"}, {"points", {{1, 1}, {9, 9}}}, {"radius", "5 parsecs"}, {"depth", 3}}, "/operations/0/radius"},
      {{{"op", "mountain_range"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}, {"height", 50}, {"spurs", 3}},
       "/operations/0/spurs"},
      {{{"op", "mountain_range"}, {"points", {{1, 1, 5}, {9, 9}}}, {"radius", 5}}, "/operations/0/points"},
      {{{"op", "peak"}, {"center", {50, 50}}, {"height", "high"}}, "/operations/0/height"},
      {{{"op", "volcano"}, {"center", {50, 50}}, {"crater", 0.9}}, "/operations/0/crater"},
      {{{"op", "canyon"}, {"points", {{1, 1}, {9, 9}}}, {"bands", -1}}, "/operations/0/bands"},
      {{{"op", "canyon"}, {"points", {{1, 1}, {9, 9}}}, {"age", 2}}, "/operations/0/age"},
      {{{"op", "mountain_range"}, {"points", {{1, 1}, {9, 9}}}, {"radius", 5}, {"height", 50}, {"profile", "square"}},
       "/operations/0/profile"},
      {{{"op", "mesa"}, {"center", {50, 50}}, {"radius", 20}, {"elevation", 100}}, "/operations/0/height"},
      {{{"op", "copy_paste"}, {"source", "/nonexistent/dem.tif"}, {"from", {0, 0, 8, 8}}, {"to", {50, 50}}}, "/operations/0/source"},
      {{{"op", "copy_paste"}, {"source", dem}, {"from", {0, 0, 800, 8}}, {"to", {50, 50}}}, "/operations/0/from"},
      {{{"op", "copy_paste"}, {"source", dem}, {"from", {0, 0, 8, 8}}, {"to", {50, 50}}, {"scale", 0}}, "/operations/0/scale"},
      {{{"op", "fit"}}, "/operations/0: needs at least one"},
      {{{"op", "fit"}, {"ridges", {{{"points", {{1, 1}, {5, 5}}}}}}}, "/operations/0/ridges/0/points/0"},
      {{{"op", "fit"}, {"contours", {{{"points", {{1, 1}, {5, 5}}}}}}}, "/operations/0/contours/0/elevation"},
      {{{"op", "regularize"}, {"strength", 2}}, "/operations/0/strength: unknown parameter"},
      {{{"op", "erode"}}, "/operations/0/steps"},
      {{{"op", "erode"}, {"steps", 10}, {"rain", -1}}, "/operations/0/rain"},
      {{{"op", "erode"}, {"steps", 10}, {"center", {5, 5}}, {"radius", 0}}, "/operations/0/radius"},
      {{{"op", "amplify"}, {"exemplar", "/nonexistent/dem.tif"}}, "/operations/0/exemplar"},
      {{{"op", "amplify"}, {"exemplar", dem}, {"factor", 3}}, "/operations/0/factor"},
      {{{"op", "strata"}, {"center", {150, 150}}, {"radius", 50}, {"top", 100}, {"thickness", -2}}, "/operations/0/thickness"},
      {{{"op", "drainage"}, {"depth", -4}}, "/operations/0/depth"},
      {{{"op", "lake"}, {"seed", {1000, 50}}}, "/operations/0/seed"},
      {{{"op", "style"}, {"style", "marble"}, {"center", {50, 50}}, {"radius", 20}}, "/operations/0/style"},
      {{{"op", "style"}, {"style", "alpine"}}, "/operations/0"},
  };
  std::set<std::string> covered;
  for (const auto& c : cases) {
    const std::string msg = validate_op(c.op);
    EXPECT_NE(msg.find("edit: "), std::string::npos) << c.op.dump() << " -> " << msg;
    EXPECT_NE(msg.find(c.path), std::string::npos) << c.op.dump() << " -> " << msg;
    covered.insert(c.op["op"].get<std::string>());
  }
  for (const auto& [name, summary] : edit_operations()) EXPECT_TRUE(covered.count(name)) << "no bad-parameter case for " << name;
}

TEST(EditParams, ScriptLevelErrors) {
  EXPECT_NE(validate(json{{"operations", {{{"op", "caldera"}}}}}).find("/operations/0/op: unknown operation 'caldera'"), std::string::npos);
  EXPECT_NE(validate(json{{"operations", {{{"op", "regularize"}}}}, {"unit", "m"}}).find("/unit: unknown key"), std::string::npos);
  EXPECT_NE(validate(json{{"operations", {{{"op", "regularize"}}}}, {"units", "feet"}}).find("/units"), std::string::npos);
  EXPECT_NE(validate(json{{"operations", 3}}).find("/operations"), std::string::npos);
  EXPECT_NE(validate(json{{"operations", {{{"op", "crest"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", 5}, {"radius", 5}, {"radus", 5}}}}})
                .find("/operations/0/radus: unknown parameter"),
            std::string::npos);
  EXPECT_EQ(validate(json{{"operations", {{{"op", "crest"}, {"points", {{1, 1}, {9, 9}}}, {"elevation", "0.1 km"}, {"radius", "20 m"}}}}}), "");
}

TEST(EditParams, CliReportsThePathAndWritesNothing) {
  test::TempDir tmp;
  write_text_file_atomic(tmp.path("bad.json"),
                         R"({"operations": [{"op": "crest", "points": [[1, 1], [9, 9]], "elevation": 5, "radius": -4}]})");
  const auto r = test::run_cli(fmt::format("edit flat:32x32@10 --script {} -o {}", tmp.path("bad.json"), tmp.path("out.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("terracl ERROR: edit: /operations/0/radius"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("out.tif")));
  write_text_file_atomic(tmp.path("broken.json"), "{\"operations\": [");
  const auto b = test::run_cli(fmt::format("edit flat:32x32 --script {} -o {}", tmp.path("broken.json"), tmp.path("out.tif")));
  EXPECT_NE(b.exit_code, 0);
  EXPECT_NE(b.out.find("malformed JSON"), std::string::npos) << b.out;
  const auto f = test::run_cli(fmt::format("edit flat:32by32 --script {} -o {}", tmp.path("bad.json"), tmp.path("out.tif")));
  EXPECT_NE(f.exit_code, 0);
  EXPECT_NE(f.out.find("flat:WIDTHxHEIGHT"), std::string::npos) << f.out;
  EXPECT_EQ(tmp.count(), 2u);  // only the two scripts
}

TEST(EditParams, CliRunsAScriptWithPreviewAndGradientImage) {
  test::TempDir tmp;
  write_text_file_atomic(tmp.path("s.json"),
                         R"({"units": "cells", "operations": [{"op": "crest", "points": [[4, 16], [28, 16]], "elevation": 80, "radius": 8},
                                                              {"op": "regularize"}]})");
  const auto r = test::run_cli(fmt::format("edit flat:32x32@10 --script {} -o {} --preview {} --gradient-image {} --report {}",
                                           tmp.path("s.json"), tmp.path("o.tif"), tmp.path("o.png"), tmp.path("g.png"),
                                           tmp.path("r.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("curl RMS"), std::string::npos) << r.out;
  const Heightfield h = read_heightfield(tmp.path("o.tif"));
  EXPECT_NEAR(h.at(16, 16), 80.0, 0.05);
  EXPECT_TRUE(std::filesystem::exists(tmp.path("o.png")));
  EXPECT_TRUE(std::filesystem::exists(tmp.path("g.png.json")));
  const GradientField g = read_gradient_image(tmp.path("g.png"));
  EXPECT_EQ(g.width, 32);
}

TEST(EditParams, PipelineRunsTheEditStage) {
  test::TempDir tmp;
  write_text_file_atomic(tmp.path("s.json"),
                         R"({"units": "cells", "operations": [{"op": "mesa", "center": [20, 20], "radius": 6, "elevation": 900, "height": 200}]})");
  const json pipeline = json::array({test::data_path("crops/frontrange_64.asc"), json{{"type", "edit"}, {"script", tmp.path("s.json")}},
                                     tmp.path("out.tif")});
  write_text_file_atomic(tmp.path("p.json"), pipeline.dump());
  const auto r = test::run_cli(fmt::format("-q run {}", tmp.path("p.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield h = read_heightfield(tmp.path("out.tif"));
  EXPECT_EQ(h.at(26, 20), 900.0f);  // the mesa's rim ring is hard, its cap free
  EXPECT_NEAR(h.at(20, 20), 900.0, 0.1 * 200);
  const json bad = json::array({test::data_path("crops/frontrange_64.asc"), json{{"type", "edit"}}, tmp.path("o2.tif")});
  write_text_file_atomic(tmp.path("bad.json"), bad.dump());
  const auto b = test::run_cli(fmt::format("-q run {}", tmp.path("bad.json")));
  EXPECT_NE(b.exit_code, 0);
  EXPECT_NE(b.out.find("script"), std::string::npos) << b.out;
}
