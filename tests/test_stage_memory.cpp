// SPDX-License-Identifier: Apache-2.0
// The stage table's memory column (terracl/stage_memory.hpp): every stage declares what
// it needs from its options and its input's size, and a run that cannot fit is refused before
// anything is read or written, by `run --validate` as by the run, by the stage subcommands and by
// `terracl edit`. TERRACL_MAX_MEMORY (host_memory_limit()) stands for a small machine.
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <terracl/memory.hpp>
#include <terracl/stage_memory.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }  // 12288 cells
std::string q(const std::string& s) { return "'" + s + "'"; }

// `terracl ARGS` with the environment variables ENV (NAME=VALUE ...).
test::CmdResult run_env(const std::string& env, const std::string& args) {
  const std::string cmd = "env " + env + " " + std::string(TERRACL_CLI) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

// `terracl ARGS` with TERRACL_MAX_MEMORY=LIMIT.
test::CmdResult run_capped(const std::string& limit, const std::string& args) {
  return run_env("TERRACL_MAX_MEMORY=" + limit, args);
}

std::string write_pipeline(const test::TempDir& dir, const std::string& name, const json& stages) {
  std::ofstream(dir.path(name)) << stages.dump();
  return dir.path(name);
}

void expect_refusal(const test::CmdResult& r, int code, const std::vector<std::string>& words, const std::string& what) {
  EXPECT_EQ(r.exit_code, code) << what << "\n" << r.out;
  for (const auto& w : words) EXPECT_NE(r.out.find(w), std::string::npos) << what << ": missing '" << w << "'\n" << r.out;
  EXPECT_EQ(r.out.find("internal"), std::string::npos) << r.out;
}

}  // namespace

TEST(StageMemory, SizesFlowThroughTheStagesThatChangeThem) {
  const RasterShape in{1000, 800};
  EXPECT_EQ(memory_of("crop", json{{"x", 10}, {"y", 0}, {"width", nullptr}, {"height", 100}}, in).output.width, 990);
  EXPECT_EQ(memory_of("crop", json{{"x", 10}, {"y", 0}, {"width", nullptr}, {"height", 100}}, in).output.height, 100);
  EXPECT_EQ(memory_of("downsample", json{{"factor", 4}}, in).output.width, 250);
  EXPECT_EQ(memory_of("amplify", json{{"factor", 16}}, in).output.height, 12800);
  EXPECT_EQ(memory_of("resize", json{{"width", 300}, {"height", 200}}, in).output.height, 200);
  EXPECT_EQ(memory_of("warp", json{{"ts", {64, 32}}}, in).output.width, 64);
  EXPECT_FALSE(memory_of("warp", json{{"tr", {5.0, 5.0}}}, in).output.known()) << "known only after GDAL computes it";
  EXPECT_EQ(memory_of("breach", json::object(), in).output.width, 1000);
  // Every stage of the table costs something per cell: none is left unchecked.
  for (const auto& s : StageRegistry::instance().all()) {
    const MemoryNeed n = memory_of(s.name, json::object(), in);
    EXPECT_GT(n.host, in.cells()) << s.name;
    EXPECT_NE(n.what.find("1000 x 800"), std::string::npos) << s.name << ": " << n.what;
  }
  // Device-side figures are declared by the device stages.
  for (const char* d : {"edit", "erode", "reconstruct", "extract"}) EXPECT_GT(memory_of(d, json::object(), in).device, 0) << d;
  EXPECT_EQ(raster_shape(crop()).width, 128);
  EXPECT_EQ(raster_shape(crop()).height, 96);
  EXPECT_FALSE(raster_shape("flat:100x100").known());
  EXPECT_FALSE(raster_shape(test::data_path("no-such-file.tif")).known());
}

TEST(StageMemory, AnalysisAndEditStagesAreRefusedByValidateAndByTheRunBeforeAnyOutput) {
  test::TempDir dir;
  const std::string script = dir.path("s.json");
  std::ofstream(script) << R"([{"op": "scale_slopes", "factor": 2}])";
  // 150 KiB: the reader (9 B/cell, 108 KiB) fits, the stage after it does not.
  struct Case {
    json stage;
    std::string words;
  };
  const std::vector<Case> cases = {
      {json{{"type", "fill_depressions"}}, "fill_depressions of a 128 x 96 raster"},
      {json{{"type", "breach"}}, "breach of a 128 x 96 raster"},
      {json{{"type", "drainage"}}, "drainage of a 128 x 96 raster"},
      {json{{"type", "sketch"}, {"file", dir.path("k.png")}}, "sketch of a 128 x 96 raster"},
      {json{{"type", "metrics"}, {"json", dir.path("m.json")}}, "metrics of a 128 x 96 raster"},
      {json{{"type", "edit"}, {"script", script}}, "edit of a 128 x 96 raster"},
  };
  for (const auto& c : cases) {
    const std::string what = c.stage.dump();
    const std::string p = write_pipeline(dir, "p.json", json::array({crop(), c.stage, dir.path("o.tif")}));
    const std::vector<std::string> words = {"/1 (" + c.words + ") needs about", "TERRACL_MAX_MEMORY", "p.json"};
    expect_refusal(run_capped("150K", "run -q --validate " + q(p)), 2, words, "--validate " + what);
    // The run makes the same check first (two cases: each CLI start costs CI time).
    if (c.stage["type"] == "metrics" || c.stage["type"] == "edit") {
      expect_refusal(run_capped("150K", "run -q " + q(p)), 2, words, "run " + what);
      for (const char* f : {"o.tif", "k.png", "m.json", "p.resolved.json"}) EXPECT_FALSE(fs::exists(dir.path(f))) << what << ": " << f;
    }
  }
  // With room it validates: the check is a figure, not a blanket refusal.
  EXPECT_EQ(run_capped("64M", "run -q --validate " + q(dir.path("p.json"))).exit_code, 0);
  // A crop before the stage shrinks what it needs: 64 x 48 fits where 128 x 96 did not (16 B/cell: 48 KiB).
  const std::string small = write_pipeline(
      dir, "small.json",
      json::array({crop(), json{{"type", "crop"}, {"width", 64}, {"height", 48}}, json{{"type", "breach"}}, dir.path("o.tif")}));
  const auto ok = run_capped("150K", "run -q --validate " + q(small));
  EXPECT_EQ(ok.exit_code, 0) << ok.out;
  // The hint says what to change: a tileable stage names --tile.
  const std::string fill = write_pipeline(dir, "f.json", json::array({crop(), "fill_depressions", dir.path("o.tif")}));
  EXPECT_NE(run_capped("150K", "run -q --validate " + q(fill)).out.find("--tile"), std::string::npos);
}

TEST(StageMemory, SubcommandsAndEditCheckTheInputHeaderBeforeReading) {
  test::TempDir dir;
  // One subcommand of each kind: generated from the stage table (breach), hand-written (metrics, mesh).
  for (const std::string& args : {"metrics -q " + q(crop()), "breach -q " + q(crop()) + " -o " + q(dir.path("b.tif")),
                                  "mesh -q " + q(crop()) + " -o " + q(dir.path("m.glb"))}) {
    const std::string name = args.substr(0, args.find(' '));
    expect_refusal(run_capped("150K", args), 1, {name + ": " + name + " of a 128 x 96 raster needs about"}, args);
  }
  const std::string script = dir.path("s.json");
  std::ofstream(script) << R"([{"op": "scale_slopes", "factor": 2}])";
  expect_refusal(run_capped("150K", "edit -q " + q(crop()) + " --script " + q(script) + " -o " + q(dir.path("e.tif"))), 1,
                 {"edit: edit of a 128 x 96 raster needs about", "use a smaller base"}, "edit DEM base");
  EXPECT_EQ(dir.count(), 1u) << "only the script may be there";
}

TEST(StageMemory, ValidateRefusesAnAmplifyWhoseOutputIsTooLarge) {
  test::TempDir dir;
  // Before, the size of an amplify output was known only when the stage ran (after reading).
  const std::string p = write_pipeline(
      dir, "a.json",
      json::array({test::data_path("dem/N44W072.hgt"), json{{"type", "amplify"}, {"factor", 256}, {"dictionary", crop()}},
                   dir.path("o.tif")}));
  expect_refusal(test::run_cli("run -q --validate " + q(p)), 2,
                 {"/1 (the x256 output of a 1201 x 1201 input): an output of 307456 x 307456 cells", "at most 65536", "smaller --factor"},
                 "amplify x256");
}

TEST(StageMemory, ValidateChecksTheDeviceMemoryFromThePlatformList) {
  test::TempDir dir;
  // POCL_MEMORY_LIMIT=1 makes PoCL's CPU device report 1 GiB of global memory: a 4500 x 4500
  // erosion (56 B/cell on the device: 1.1 GiB) does not fit it; its host side (1.6 GiB) does.
  const std::string p = write_pipeline(
      dir, "d.json",
      json::array({crop(), json{{"type", "resize"}, {"width", 4500}, {"height", 4500}}, json{{"type", "erode"}, {"steps", 2}},
                   dir.path("o.tif")}));
  const std::vector<std::string> words = {"d.json", "/2 (erode of a 4500 x 4500 raster) needs about 1.1 GiB of device memory",
                                          "has 1.0 GiB", "crop or downsample"};
  const auto capped = [](const std::string& args) { return run_env("POCL_MEMORY_LIMIT=1", args); };
  expect_refusal(capped("run -q --validate " + q(p)), 2, words, "--validate");
  // The run makes the same check when it opens the device, before anything is read or written.
  expect_refusal(capped("run -q " + q(p)), 2, words, "run");
  EXPECT_EQ(dir.count(), 1u) << "only the pipeline may be there";
  // The device's real memory (PoCL: a share of the host's) holds it: a figure, not a refusal.
  const auto ok = test::run_cli("run -q --validate " + q(p));
  EXPECT_EQ(ok.exit_code, 0) << ok.out;
}
