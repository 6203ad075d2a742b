// SPDX-License-Identifier: Apache-2.0
// `terracl run`, `terracl stages` and the stage subcommands, run as a user runs them: exit codes,
// messages naming the JSON path, overrides, progress JSON lines, Ctrl-C, and docs/stages.md being
// the built CLI's stage table.
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }

std::string write_pipeline(const test::TempDir& dir, const std::string& name, const json& doc) {
  const std::string path = dir.path(name);
  std::ofstream(path) << doc.dump(2);
  return path;
}

std::string q(const std::string& s) { return "'" + s + "'"; }

bool has_temporary(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(RunCli, ValidPipelineRunsEndToEndAndPrintsWhatItWrote) {
  test::TempDir dir;
  const std::string p = write_pipeline(
      dir, "crop.json",
      json::array({crop(), "fill_nodata", dir.path("out/c.tif"), dir.path("out/c.exr"), dir.path("out/c.png")}));
  const auto r = test::run_cli("run " + q(p));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const auto& f : {"out/c.tif", "out/c.exr", "out/c.png", "out/c.png.json", "out/crop.resolved.json"})
    EXPECT_TRUE(fs::exists(dir.path(f))) << f;
  // The table names every stage with its time and every file written.
  for (const auto& s : {"read", "fill_nodata", "write1", "write2", "write3", "out/c.tif (", "out/c.png (", " s "})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
  EXPECT_NE(r.out.find("resolved pipeline: " + dir.path("out/crop.resolved.json")), std::string::npos) << r.out;
  const Heightfield a = read_heightfield(crop()), b = read_heightfield(dir.path("out/c.exr"));
  ASSERT_EQ(a.z, b.z);
  EXPECT_EQ(b.metadata.count("terracl:pipeline_hash"), 1u);
}

TEST(RunCli, InvalidPipelinesFailAtValidateWithTheJsonPath) {
  test::TempDir dir;
  GradientField g(8, 6);
  write_gradient(g, dir.path("g.exr"));
  const std::string out = dir.path("o.tif");
  struct Case {
    json doc;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {json::array({crop(), json{{"type", "no_such_stage"}}, out}), "/1/type: unknown stage 'no_such_stage'"},
      {json::array({json{{"type", "read"}, {"filename", crop()}, {"fill_nodata", 1.5}}, out}),
       "/0/fill_nodata: expected true or false"},
      {json::array({dir.path("missing.tif"), out}),
       "/0/filename: input file " + dir.path("missing.tif") + " does not exist"},
      {json::array({crop(), json{{"type", "write"}, {"filename", dir.path("o.png")}, {"zmax", "2 furlongs"}}}),
       "/1/zmax: unknown unit 'furlongs'"},
      {json::array(), "/: the pipeline is empty"},
      {json::array({dir.path("g.exr"), "fill_nodata", out}),
       "/1: stage 'fill_nodata' (fill_nodata) needs a heightfield as input, but the stage before it ('read') produces "
       "a gradient"},
      {json::array({dir.path("g.exr"), dir.path("o.png")}),
       "/1/filename: " + dir.path("o.png") + ": a gradient is written as .exr (two float channels) or .tif"},
      {json::array({json{{"type", "write"}, {"filename", out}}}),
       "/0: stage 'write' (write) needs a heightfield or gradient as input"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string p = write_pipeline(dir, "bad" + std::to_string(i) + ".json", cases[i].doc);
    const auto r = test::run_cli("run --validate " + q(p));
    EXPECT_EQ(r.exit_code, 2) << cases[i].doc.dump() << "\n" << r.out;
    EXPECT_NE(r.out.find("terracl ERROR: pipeline: " + p + ": " + cases[i].expected), std::string::npos)
        << cases[i].doc.dump() << "\n"
        << r.out;
  }
  EXPECT_FALSE(fs::exists(out));
  // Not JSON at all: the parser's line and column.
  std::ofstream(dir.path("broken.json")) << "[\"a.tif\",\n";
  const auto r = test::run_cli("run --validate " + q(dir.path("broken.json")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("not valid JSON"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("line 2"), std::string::npos) << r.out;
}

TEST(RunCli, ValidateChecksWithoutRunning) {
  test::TempDir dir;
  const std::string p = write_pipeline(dir, "v.json", json::array({crop(), dir.path("out/v.tif")}));
  const auto r = test::run_cli("run --validate " + q(p));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("valid pipeline, 2 stages"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nothing -> heightfield"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir.path("out"))) << "--validate must not write anything";
}

TEST(RunCli, SetOverridesApply) {
  test::TempDir dir;
  const std::string p = write_pipeline(dir, "s.json", json::array({crop(), dir.path("a.png")}));
  const auto r = test::run_cli("run -q " + q(p) + " --set " + q("write.filename=" + dir.path("b.png")) +
                               " --set 'write.zmin=100' --set 'write.zmax=1.5 km'");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_FALSE(fs::exists(dir.path("a.png")));
  ASSERT_TRUE(fs::exists(dir.path("b.png")));
  const json sidecar = json::parse(test::file_bytes(dir.path("b.png.json")));
  EXPECT_EQ(sidecar["zmin"].get<double>(), 100.0);
  EXPECT_EQ(sidecar["zmax"].get<double>(), 1500.0);
  // The resolved pipeline records the overridden values.
  const json resolved = json::parse(test::file_bytes(dir.path("s.resolved.json")));
  EXPECT_EQ(resolved["pipeline"][1]["filename"], dir.path("b.png"));
  EXPECT_EQ(resolved["pipeline"][1]["zmax"].get<double>(), 1500.0);
  // Overrides naming nothing are usage errors.
  for (const auto& [set, msg] : std::vector<std::pair<std::string, std::string>>{
           {"erode.steps=3", "no stage is tagged 'erode'"},
           {"write.steps=3", "stage 'write' (write) has no option 'steps'"},
           {"write", "--set expects TAG.OPTION=VALUE"},
           {"write.zmax=high", "--set write.zmax=high: /1/zmax: 'high' is not a number with a unit"}}) {
    const auto e = test::run_cli("run --validate " + q(p) + " --set " + q(set));
    EXPECT_EQ(e.exit_code, 2) << set << "\n" << e.out;
    EXPECT_NE(e.out.find(msg), std::string::npos) << set << "\n" << e.out;
  }
}

TEST(RunCli, ResolvedPipelineRerunsToTheSameBytes) {
  test::TempDir dir;
  const std::string p = write_pipeline(
      dir, "r.json",
      json::array({crop(), "fill_nodata", dir.path("o/r.tif"), dir.path("o/r.exr"), dir.path("o/r.r16")}));
  ASSERT_EQ(test::run_cli("run -q " + q(p)).exit_code, 0);
  std::map<std::string, std::string> first;
  for (const auto& f : {"o/r.tif", "o/r.exr", "o/r.r16", "o/r.r16.json", "o/r.resolved.json"})
    first[f] = test::file_bytes(dir.path(f));
  sleep(1);  // a timestamp in any output would now differ
  const auto again = test::run_cli("run -q " + q(dir.path("o/r.resolved.json")));
  ASSERT_EQ(again.exit_code, 0) << again.out;
  for (const auto& [f, bytes] : first) {
    ASSERT_FALSE(bytes.empty()) << f;
    EXPECT_TRUE(test::file_bytes(dir.path(f)) == bytes) << f << " differs after re-running the resolved pipeline";
  }
}

TEST(RunCli, ProgressJsonLines) {
  test::TempDir dir;
  const std::string p = write_pipeline(dir, "j.json", json::array({crop(), "fill_nodata", dir.path("j.tif")}));
  const auto r = test::run_cli("run --progress=json " + q(p));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::istringstream lines(r.out);
  std::string line;
  std::set<std::string> started, finished;
  json done;
  while (std::getline(lines, line)) {
    const json j = json::parse(line);  // every line is JSON
    if (j.contains("event")) {
      done = j;
      continue;
    }
    ASSERT_TRUE(j["fraction"].is_number()) << line;
    (j["fraction"].get<double>() == 0.0 ? started : finished).insert(j["stage"].get<std::string>());
  }
  EXPECT_EQ(started, (std::set<std::string>{"read", "fill_nodata", "write"}));
  EXPECT_EQ(finished, started);
  EXPECT_EQ(done["event"], "done");
  EXPECT_EQ(done["outputs"], json::array({dir.path("j.tif")}));
  EXPECT_EQ(done["stages"].size(), 3u);
  // -q prints no progress, only the table.
  const auto quiet = test::run_cli("-q run " + q(p));
  ASSERT_EQ(quiet.exit_code, 0) << quiet.out;
  EXPECT_EQ(quiet.out.find("\"fraction\""), std::string::npos) << quiet.out;
}

// Ctrl-C during a run: the run stops at the next stage boundary, exits non-zero with a clear
// message, and leaves complete files only.
TEST(RunCli, CtrlCStopsCleanly) {
  test::TempDir dir;
  json doc = json::array({test::data_path("dem/N44W072.hgt")});
  for (int i = 0; i < 12; ++i) doc.push_back(dir.path("out/t" + std::to_string(i) + ".exr"));
  const std::string p = write_pipeline(dir, "c.json", doc);

  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    close(fds[0]);
    execl(TERRACL_CLI, TERRACL_CLI, "--progress=json", "run", p.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[1]);
  FILE* out = fdopen(fds[0], "r");
  std::string all;
  char buf[4096];
  bool sent = false;
  while (fgets(buf, sizeof buf, out)) {
    all += buf;
    if (!sent && all.find("\"stage\"") != std::string::npos) {
      kill(pid, SIGINT);  // as soon as the run has started
      sent = true;
    }
  }
  fclose(out);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(sent) << all;
  ASSERT_TRUE(WIFEXITED(status)) << all;
  EXPECT_EQ(WEXITSTATUS(status), 130) << all;
  EXPECT_NE(all.find("terracl ERROR: run: cancelled by Ctrl-C during stage"), std::string::npos) << all;
  EXPECT_NE(all.find("no partial file was left"), std::string::npos) << all;
  EXPECT_FALSE(fs::exists(dir.path("out/t11.exr"))) << "the run went on after Ctrl-C\n" << all;
  EXPECT_FALSE(has_temporary(dir.dir()));
  EXPECT_FALSE(fs::exists(dir.path("out/c.resolved.json")));
  // Whatever was written is complete.
  for (int i = 0; i < 12; ++i)
    if (fs::exists(dir.path("out/t" + std::to_string(i) + ".exr")))
      EXPECT_EQ(read_heightfield(dir.path("out/t" + std::to_string(i) + ".exr")).width, 1201);
}

TEST(RunCli, UsageErrorsExitTwo) {
  test::TempDir dir;
  const std::vector<std::string> bad = {
      "run",                                                       // no pipeline file
      "run " + q(dir.path("none.json")),                           // missing pipeline file
      "fill_nodata",                                               // no input
      "fill_nodata " + q(crop()) + " -o " + q(dir.path("x.xyz")),  // unwritable extension
      "fill_nodata " + q(crop()) + " -o " + q(dir.path("x.tif")) + " --no-such-option 3",
      "stages --no-such-flag",
  };
  for (const auto& args : bad) {
    const auto r = test::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("terracl ERROR:"), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_EQ(dir.count(), 0u) << "a usage error wrote something";
}

TEST(StagesDoc, MatchesTheStageTable) {
  const auto r = test::run_cli("stages --markdown");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string doc = test::file_bytes(test::data_path("../docs/stages.md"));
  EXPECT_TRUE(r.out == doc) << "docs/stages.md is out of date: run scripts/gen-docs.sh and commit it";
  // Every stage of the table has its section.
  for (const auto& s : StageRegistry::instance().all())
    EXPECT_NE(doc.find("\n## " + s.name + "\n"), std::string::npos) << s.name;
}

TEST(StagesCli, HelpShowsTheOptionsFromTheTable) {
  const auto list = test::run_cli("stages");
  ASSERT_EQ(list.exit_code, 0) << list.out;
  for (const auto& s : StageRegistry::instance().all()) {
    EXPECT_NE(list.out.find(s.name), std::string::npos) << s.name;
    EXPECT_NE(list.out.find(s.description), std::string::npos) << s.name;
    if (!s.cli) {
      // "(pipeline only)" exactly when no subcommand runs the stage (render, warp, ... have
      // hand-written ones; issue 15 found them all labelled pipeline only).
      const bool command = test::run_cli("--help").out.find("\n  " + s.name + " ") != std::string::npos;
      EXPECT_EQ(list.out.find(s.description + " (pipeline only)") != std::string::npos, !command) << s.name;
      continue;
    }
    const auto r = test::run_cli(s.name + " --help");
    ASSERT_EQ(r.exit_code, 0) << s.name << "\n" << r.out;
    EXPECT_NE(r.out.find(s.description), std::string::npos) << s.name << "\n" << r.out;
    EXPECT_NE(r.out.find("-o,--output"), std::string::npos) << s.name << "\n" << r.out;
    for (const auto& o : s.options) {
      std::string flag = "--" + o.name;
      for (char& c : flag)
        if (c == '_') c = '-';
      EXPECT_NE(r.out.find(flag), std::string::npos) << s.name << " " << flag << "\n" << r.out;
      EXPECT_NE(r.out.find(o.help.substr(0, 30)), std::string::npos) << s.name << " " << o.name << "\n" << r.out;
      if (!o.unit.empty()) EXPECT_NE(r.out.find("[" + o.unit + "]"), std::string::npos) << s.name << " " << o.name;
    }
  }
}
