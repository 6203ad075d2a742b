// SPDX-License-Identifier: Apache-2.0
// Pipelines through the library API: parsing and shorthands, tags, overrides, validation errors
// with JSON paths (data-kind chaining checked with two test-only stages on a local registry), a
// real run on a crop with provenance, cancellation, and the bit-for-bit re-run of the resolved file.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }

// The message of the UsageError that validating `doc` throws ("" when it validates).
std::string validation_error(const json& doc, const StageRegistry& reg = StageRegistry::instance()) {
  try {
    Pipeline p = Pipeline::parse(doc, "t", "t.json", reg);
    p.validate();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

// A registry with the real read/write stages plus two test-only stages that change the data kind
// like extract and reconstruct do (host loops: forward differences and their running sum).
StageRegistry kind_registry() {
  StageRegistry reg;
  reg.add(*StageRegistry::instance().find("read"));
  reg.add(*StageRegistry::instance().find("write"));
  reg.add({"test_extract",
           "Forward differences (test only).",
           DataKind::Heightfield,
           DataKind::Gradient,
           {},
           [](StageContext& c) {
             const Heightfield& h = c.height();
             GradientField g(h.width, h.height);
             g.georef = h.georef;
             for (int y = 0; y < h.height; ++y)
               for (int x = 0; x < h.width; ++x) {
                 const size_t i = size_t(y) * h.width + x;
                 if (x + 1 < h.width) g.gx[i] = float((h.at(x + 1, y) - h.at(x, y)) / h.georef.cell_x);
                 if (y + 1 < h.height) g.gy[i] = float((h.at(x, y + 1) - h.at(x, y)) / h.georef.cell_y);
               }
             c.data.gradient = std::move(g);
           }});
  reg.add({"test_integrate",
           "Row-wise running sum of gx (test only).",
           DataKind::Gradient,
           DataKind::Heightfield,
           {{"base", OptionType::Float, 0.0, "m", "Elevation of the first column"}},
           [](StageContext& c) {
             const GradientField& g = c.gradient();
             Heightfield h(g.width, g.height);
             h.georef = g.georef;
             for (int y = 0; y < g.height; ++y) {
               double z = c.get<double>("base");
               for (int x = 0; x < g.width; ++x) {
                 h.at(x, y) = float(z);
                 z += g.gx[size_t(y) * g.width + x] * g.georef.cell_x;
               }
             }
             c.data.height = std::move(h);
           }});
  // Like metrics or render: writes a file of its own and passes the heightfield on.
  reg.add({"test_report",
           "Writes the mean elevation as JSON (test only).",
           DataKind::Heightfield,
           DataKind::None,
           {{"json", OptionType::OutputPath, nullptr, "", "Report file", {}, true}},
           [](StageContext& c) {
             write_text_file_atomic(c.get<std::string>("json"), json{{"mean", compute_stats(c.height()).mean}}.dump());
           }});
  return reg;
}

}  // namespace

TEST(Pipeline, ShorthandsExpandAndTagsDefaultToTheType) {
  const json doc = json::parse(
      R"(["in.tif", "fill_nodata", "a.tif", {"filename": "b.exr"}, {"type": "write", "tag": "last", "filename": "c.png"}])");
  const Pipeline p = Pipeline::parse(doc, "t", "t.json");
  ASSERT_EQ(p.stages().size(), 5u);
  const char* types[] = {"read", "fill_nodata", "write", "write", "write"};
  const char* tags[] = {"read", "fill_nodata", "write1", "write2", "last"};
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(p.stages()[i].type, types[i]) << i;
    EXPECT_EQ(p.stages()[i].tag, tags[i]) << i;
    EXPECT_EQ(p.stages()[i].where, "/" + std::to_string(i));
  }
  EXPECT_EQ(p.stages()[0].options.at("filename"), "in.tif");
  EXPECT_EQ(p.stages()[3].options.at("filename"), "b.exr");
  // The object form with a "pipeline" array names paths under /pipeline.
  const Pipeline q = Pipeline::parse(json{{"pipeline", json::array({"in.tif", "o.tif"})}}, "t", "t.json");
  EXPECT_EQ(q.stages()[1].where, "/pipeline/1");
}

TEST(Pipeline, DuplicateTagsAreRefused) {
  EXPECT_NE(validation_error(
                json::parse(
                    R"([{"type":"read","tag":"x","filename":"a.tif"}, {"type":"write","tag":"x","filename":"b.tif"}])"))
                .find("/1/tag: tag 'x' is already used by /0"),
            std::string::npos);
  // An explicit tag may not take the automatic tag of another stage.
  EXPECT_NE(validation_error(
                json::parse(R"(["a.tif", {"type":"write","tag":"write1","filename":"b.tif"}, "c.tif", "d.tif"])"))
                .find("tag 'write1' is also the automatic tag"),
            std::string::npos);
}

TEST(Pipeline, ValidationErrorsNameTheJsonPath) {
  const std::string c = crop();
  struct Case {
    std::string doc, expected;
  };
  const std::vector<Case> cases = {
      {"[]", "t.json: /: the pipeline is empty"},
      {R"({"stages": []})", "/stages: unknown key"},
      {R"([")" + c + R"(", {"type": "erodee"}, "o.tif"])", "/1/type: unknown stage 'erodee'"},
      {R"([{"type": "read", "filename": ")" + c + R"(", "fill_nodata": "yes"}, "o.tif"])",
       "/0/fill_nodata: expected true or false"},
      {R"([{"type": "read", "filename": ")" + c + R"(", "colour": 1}, "o.tif"])",
       "/0/colour: stage 'read' has no option 'colour'"},
      // render writes to "file"; "filename" (the write stage's) is pointed at it, as a near miss is.
      {R"([")" + c + R"(", {"type": "render", "filename": "o.png"}])",
       "/1/filename: stage 'render' has no option 'filename'; did you mean 'file'?"},
      {R"([")" + c + R"(", {"type": "erode", "step": 3}, "o.tif"])", "/1/step: stage 'erode' has no option 'step'; did you mean 'steps'?"},
      {R"(["no/such/file.tif", "o.tif"])", "/0/filename: input file no/such/file.tif does not exist"},
      {R"([")" + c + R"(", {"type": "write", "filename": "o.png", "zmax": "3 parsec"}])",
       "/1/zmax: unknown unit 'parsec'"},
      {R"([")" + c + R"(", {"type": "write", "filename": "o.png", "zmax": "3 s"}])",
       "/1/zmax: unit 's' is not a length unit"},
      {R"([{"type": "write", "filename": "o.tif"}])",
       "/0: stage 'write' (write) needs a heightfield or gradient as input, but nothing comes before it"},
      {R"([")" + c + R"("])", "the pipeline writes nothing"},
      {R"([")" + c + R"(", "o.xyz1"])", "/1/filename: cannot write a heightfield there: o.xyz1: no GDAL driver writes"},
      {R"([")" + c + R"(", "o.tif", "./o.tif"])", "/2/filename: ./o.tif is also written by /1/filename"},
      {R"([")" + c + R"(", ")" + c + R"("])", "is an input of this pipeline (/0/filename)"},
      {R"([")" + c + R"(", "fill_nodta", "o.tif"])", "/1: 'fill_nodta' is neither a stage nor a file name"},
      {R"([")" + c + R"(", 42])", "/1: expected a stage object or a file name, got 42"},
      {R"([")" + c + R"(", {"tag": "x"}])", "/1: a stage needs a \"type\""},
  };
  for (const auto& k : cases) {
    const std::string e = validation_error(json::parse(k.doc));
    EXPECT_NE(e.find(k.expected), std::string::npos) << k.doc << "\n  gave: " << e;
    EXPECT_EQ(e.rfind("pipeline: t.json: ", 0), 0u) << e;
  }
}

TEST(Pipeline, DataKindsMustChain) {
  test::TempDir dir;
  const StageRegistry reg = kind_registry();
  const std::string c = crop(), out = dir.path("g.exr");
  // A reconstruct-like stage fed a heightfield.
  EXPECT_NE(
      validation_error(json::array({c, "test_integrate", out}), reg)
          .find(
              "/1: stage 'test_integrate' (test_integrate) needs a gradient as input, but the stage before it ('read') "
              "produces a heightfield"),
      std::string::npos);
  // An extract-like stage followed by a heightfield-only format.
  EXPECT_NE(validation_error(json::array({c, "test_extract", dir.path("g.png")}), reg)
                .find("/2/filename: " + dir.path("g.png") + ": a gradient is written as .exr"),
            std::string::npos);
  // A gradient file read from disk is a gradient: a heightfield stage after it is refused.
  GradientField g(8, 6);
  write_gradient(g, dir.path("in_g.exr"));
  EXPECT_NE(
      validation_error(json::array({dir.path("in_g.exr"), "fill_nodata", dir.path("o.tif")}))
          .find("/1: stage 'fill_nodata' (fill_nodata) needs a heightfield as input, but the stage before it ('read') "
                "produces a gradient"),
      std::string::npos);
  EXPECT_EQ(validation_error(json::array({c, "test_extract", out, "test_integrate", dir.path("h.tif")}), reg), "");
}

TEST(Pipeline, KindChangingStagesRunAndTheirOutputsReadBack) {
  test::TempDir dir;
  const StageRegistry reg = kind_registry();
  const json doc = json::array({crop(), "test_extract", dir.path("g.exr"),
                                json{{"type", "test_integrate"}, {"base", "1 km"}}, dir.path("h.tif")});
  Pipeline p = Pipeline::parse(doc, "kinds", "kinds.json", reg);
  p.validate();
  EXPECT_EQ(p.stages()[3].options.at("base").get<double>(), 1000.0);
  RunReport r;
  p.run({}, r);
  const Heightfield in = read_heightfield(crop());
  const GradientField g = read_gradient(dir.path("g.exr"));
  ASSERT_EQ(g.width, in.width);
  EXPECT_EQ(g.metadata.at("terracl:pipeline_hash"), p.hash());
  EXPECT_EQ(json::parse(g.metadata.at("terracl:stages"))[1]["type"], "test_extract");
  EXPECT_FLOAT_EQ(g.gx[0], float((in.at(1, 0) - in.at(0, 0)) / in.georef.cell_x));
  const Heightfield h = read_heightfield(dir.path("h.tif"));
  // Integrating the row differences gives the input back up to its first column (float error).
  for (int y = 0; y < in.height; y += 17)
    for (int x = 0; x < in.width; x += 13)
      EXPECT_NEAR(h.at(x, y) - 1000.0, in.at(x, y) - in.at(0, y), 1e-2) << x << "," << y;
}

TEST(Pipeline, OverridesApplyAndAreChecked) {
  test::TempDir dir;
  Pipeline p = Pipeline::parse(json::array({crop(), dir.path("a.png")}), "t", "t.json");
  p.set("write.filename=" + dir.path("b.png"));
  p.set("write.zmax=2 km");
  p.set("read.fill_nodata=true");
  p.validate();
  EXPECT_EQ(p.outputs(), std::vector<std::string>{dir.path("b.png")});
  EXPECT_EQ(p.stages()[1].options.at("zmax").get<double>(), 2000.0);
  EXPECT_EQ(p.stages()[0].options.at("fill_nodata"), true);
  EXPECT_EQ(p.resolved_path(), dir.path("t.resolved.json"));
  auto err = [&](const std::string& s) {
    try {
      p.set(s);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(err("wrte.filename=x.tif").find("no stage is tagged 'wrte' (tags: read, write)"), std::string::npos);
  EXPECT_NE(err("write.colour=red").find("stage 'write' (write) has no option 'colour'"), std::string::npos);
  EXPECT_NE(err("write.zmax").find("--set expects TAG.OPTION=VALUE"), std::string::npos);
  EXPECT_NE(err("read.fill_nodata=maybe").find("--set read.fill_nodata=maybe: /0/fill_nodata: expected true or false"),
            std::string::npos);
  EXPECT_NE(err("write.zmax=2 parsec").find("unknown unit 'parsec'"), std::string::npos);
}

TEST(Pipeline, RunsOnACropWithProvenance) {
  test::TempDir dir;
  // The crop with a hole of nodata, so that fill_nodata has work to do.
  Heightfield holed = read_heightfield(crop());
  for (int y = 40; y < 50; ++y)
    for (int x = 60; x < 75; ++x) holed.at(x, y) = NAN;
  write_heightfield(holed, dir.path("holed.tif"));
  const std::string out = dir.path("out/filled.tif");
  Pipeline p = Pipeline::parse(json::array({dir.path("holed.tif"), "fill_nodata", out, dir.path("out/filled.r16")}),
                               "fill", "fill.json");
  p.validate();
  RunReport r;
  p.run({}, r);
  ASSERT_EQ(r.stages.size(), 4u);
  EXPECT_EQ(r.outputs(), (std::vector<std::string>{out, dir.path("out/filled.r16")}));
  EXPECT_EQ(r.resolved_path, dir.path("out/fill.resolved.json"));
  for (const auto& s : r.stages) EXPECT_GE(s.seconds, 0.0);

  // Same values as the library's fill on the same input; untouched cells exactly the input.
  Heightfield expected = read_heightfield(dir.path("holed.tif"));
  fill_nodata_harmonic(expected);
  const Heightfield got = read_heightfield(out);
  ASSERT_EQ(got.z.size(), expected.z.size());
  EXPECT_EQ(got.count_nodata(), 0u);
  for (size_t i = 0; i < got.z.size(); ++i) ASSERT_EQ(got.z[i], expected.z[i]) << i;

  EXPECT_EQ(got.metadata.at("terracl:pipeline_hash"), p.hash());
  EXPECT_EQ(got.metadata.at("terracl:pipeline"), "fill");
  const json stages = json::parse(got.metadata.at("terracl:stages"));
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_EQ(stages[0]["type"], "read");
  EXPECT_EQ(stages[0]["options"]["filename"], dir.path("holed.tif"));
  EXPECT_EQ(stages[1]["type"], "fill_nodata");
  // The RAW16 sidecar carries the same provenance.
  const json sidecar = json::parse(test::file_bytes(dir.path("out/filled.r16.json")));
  EXPECT_EQ(sidecar["metadata"]["terracl:pipeline_hash"], p.hash());
  // The resolved file is a pipeline that names the same hash.
  const json resolved = json::parse(test::file_bytes(r.resolved_path));
  EXPECT_EQ(resolved["terracl"]["pipeline_hash"], p.hash());
  EXPECT_EQ(resolved["pipeline"][2]["tag"], "write1");
}

TEST(Pipeline, ResolvedPipelineRerunsBitForBit) {
  test::TempDir dir;
  const json doc =
      json::parse(R"([")" + crop() + R"(", "fill_nodata", ")" + dir.path("o/a.tif") + R"(", ")" + dir.path("o/a.exr") +
                  R"(", {"filename": ")" + dir.path("o/a.png") + R"(", "zmin": "0.3 km", "zmax": 1200}])");
  Pipeline p = Pipeline::parse(doc, "demo", "demo.json");
  p.validate();
  RunReport r1;
  p.run({}, r1);
  std::map<std::string, std::string> first;
  for (const auto& f : {"o/a.tif", "o/a.exr", "o/a.png", "o/a.png.json", "o/demo.resolved.json"})
    first[f] = test::file_bytes(dir.path(f));

  Pipeline again = Pipeline::load(r1.resolved_path);
  EXPECT_EQ(again.name(), "demo");
  again.validate();
  EXPECT_EQ(again.hash(), p.hash());
  EXPECT_EQ(again.resolved(), p.resolved());
  RunReport r2;
  again.run({}, r2);
  EXPECT_EQ(r2.resolved_path, r1.resolved_path);
  for (const auto& [f, bytes] : first) {
    ASSERT_FALSE(bytes.empty()) << f;
    EXPECT_TRUE(test::file_bytes(dir.path(f)) == bytes) << f << " differs after re-running the resolved pipeline";
  }
}

TEST(Pipeline, CancelStopsBetweenStagesWithoutPartialFiles) {
  test::TempDir dir;
  Pipeline p =
      Pipeline::parse(json::array({crop(), dir.path("a.tif"), dir.path("b.exr"), dir.path("c.png")}), "t", "t.json");
  p.validate();
  RunOptions ro;
  // Like Ctrl-C pressed during write1: the next progress callback (write2's start) says stop.
  ro.progress = [](const std::string& tag, size_t, size_t) -> Progress {
    return [tag](double, const std::string&) { return tag != "write2"; };
  };
  RunReport r;
  EXPECT_THROW(p.run(ro, r), Cancelled);
  EXPECT_EQ(r.running, "write2");
  ASSERT_EQ(r.stages.size(), 2u);  // read and write1 completed
  EXPECT_TRUE(fs::exists(dir.path("a.tif")));
  EXPECT_FALSE(fs::exists(dir.path("b.exr")));
  EXPECT_FALSE(fs::exists(dir.path("c.png")));
  EXPECT_FALSE(fs::exists(dir.path("t.resolved.json"))) << "a stopped run must not claim to be complete";
  for (const auto& e : fs::directory_iterator(dir.dir()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(Pipeline, ReadsAFileWrittenEarlierInThePipeline) {
  test::TempDir dir;
  Pipeline p =
      Pipeline::parse(json::array({crop(), dir.path("mid.tif"),
                                   json{{"type", "read"}, {"filename", dir.path("mid.tif")}}, dir.path("end.exr")}),
                      "t", "t.json");
  p.validate();
  RunReport r;
  p.run({}, r);
  const Heightfield a = read_heightfield(crop()), b = read_heightfield(dir.path("end.exr"));
  ASSERT_EQ(a.z.size(), b.z.size());
  for (size_t i = 0; i < a.z.size(); ++i) ASSERT_EQ(a.z[i], b.z[i]);
}

TEST(Pipeline, CropKeepsValuesAndGeoreferencing) {
  test::TempDir dir;
  Pipeline p = Pipeline::parse(
      json::array({crop(), json{{"type", "crop"}, {"x", 10}, {"y", 20}, {"width", 50}, {"height", "30 cells"}},
                   dir.path("c.tif")}),
      "t", "t.json");
  p.validate();
  RunReport r;
  p.run({}, r);
  const Heightfield a = read_heightfield(crop()), c = read_heightfield(dir.path("c.tif"));
  ASSERT_EQ(c.width, 50);
  ASSERT_EQ(c.height, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 50; ++x) ASSERT_EQ(c.at(x, y), a.at(x + 10, y + 20));
  // GDAL's own numbers for this window: origin moves by 10 and 20 cells of 3 arc-seconds.
  EXPECT_NEAR(c.georef.geotransform[0], a.georef.geotransform[0] + 10 * a.georef.geotransform[1], 1e-12);
  EXPECT_NEAR(c.georef.geotransform[3], a.georef.geotransform[3] + 20 * a.georef.geotransform[5], 1e-12);
  EXPECT_NEAR(c.georef.cell_y, a.georef.cell_y, 1e-3 * a.georef.cell_y);
  // A window outside the raster is a clear error naming the stage.
  Pipeline bad = Pipeline::parse(
      json::array({crop(), json{{"type", "crop"}, {"x", 100}, {"width", 50}}, dir.path("d.tif")}), "t", "t.json");
  bad.validate();
  try {
    bad.run({}, r);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("crop: window x 100..149, y 0..95 does not fit in the 128 x 96 raster"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("(pipeline stage /1, tag 'crop')"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.path("d.tif")));
}

// The main job (scripts/demo.sh) must keep running as stages change. Its file names are relative
// to the repository root, so it runs in a temporary folder where data/ links to the repository's.
TEST(Pipeline, DemoPipelineRunsEndToEnd) {
  test::TempDir dir;
  fs::create_directory_symlink(fs::path(TERRACL_SOURCE_DIR) / "data", dir.dir() / "data");
  const fs::path before = fs::current_path();
  fs::current_path(dir.dir());
  try {
    Pipeline p = Pipeline::load("data/pipelines/demo.json");
    p.validate();
    EXPECT_EQ(p.name(), "demo");
    RunReport r;
    p.run({}, r);
    ASSERT_EQ(r.stages.size(), p.stages().size());
    EXPECT_GE(r.outputs().size(), 5u);
    for (const auto& f : r.outputs()) EXPECT_GT(fs::file_size(f), 0u) << f;
    EXPECT_EQ(r.resolved_path, "out/presidential/demo.resolved.json");
    EXPECT_TRUE(fs::exists(r.resolved_path));
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
  }
  fs::current_path(before);
}

TEST(Pipeline, StagesWritingTheirOwnFilesPassTheirInputOn) {
  test::TempDir dir;
  const StageRegistry reg = kind_registry();
  Pipeline p = Pipeline::parse(
      json::array({crop(), json{{"type", "test_report"}, {"json", dir.path("reports/r.json")}}, dir.path("h.exr")}),
      "t", "t.json", reg);
  p.validate();
  EXPECT_EQ(p.stages()[1].output, DataKind::Heightfield);
  EXPECT_EQ(p.outputs(), (std::vector<std::string>{dir.path("reports/r.json"), dir.path("h.exr")}));
  EXPECT_EQ(p.resolved_path(), dir.path("reports/t.resolved.json"));
  RunReport r;
  p.run({}, r);
  EXPECT_EQ(r.stages[1].outputs, std::vector<std::string>{dir.path("reports/r.json")});
  const Heightfield in = read_heightfield(crop()), out = read_heightfield(dir.path("h.exr"));
  EXPECT_EQ(in.z, out.z);
  std::ifstream rep(dir.path("reports/r.json"));
  EXPECT_NEAR(json::parse(rep)["mean"].get<double>(), compute_stats(in).mean, 1e-9);
}
