// SPDX-License-Identifier: Apache-2.0
// Docs and CLI agree: info and metrics report the same slope, `run --validate`
// keeps its columns aligned past /pipeline/10, and docs/pipelines.md describes the demo as it is.
// (The "(pipeline only)" labels are checked in test_pipeline_cli.cpp, StagesCli.)
#include "test_helpers.hpp"

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>

using namespace terracl;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

}  // namespace

TEST(CliDocs, InfoAndMetricsReportTheSameSlope) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const auto info = test::run_cli("info --json " + q(in));
  ASSERT_EQ(info.exit_code, 0) << info.out;
  const auto m = test::run_cli("metrics " + q(in) + " --json " + q(dir.path("m.json")));
  ASSERT_EQ(m.exit_code, 0) << m.out;
  const auto i = nlohmann::json::parse(info.out);
  std::ifstream mf(dir.path("m.json"));
  const auto mj = nlohmann::json::parse(mf);
  EXPECT_NEAR(i["mean_slope_deg"].get<double>(), mj["slope_deg"]["mean"].get<double>(), 1e-6);
  EXPECT_NEAR(i["max_slope_deg"].get<double>(), mj["slope_deg"]["max"].get<double>(), 1e-6);
  const auto text = test::run_cli("info " + q(in));
  EXPECT_NE(text.out.find("Horn"), std::string::npos) << "info says which slope it reports\n" << text.out;
}

TEST(CliDocs, ValidateTableStaysAlignedPastTenStages) {
  test::TempDir dir;
  nlohmann::json p = nlohmann::json::array();
  p.push_back(test::data_path("crops/presidential_128x96.tif"));
  for (int i = 0; i < 11; ++i)
    p.push_back({{"type", "crop"}, {"tag", i == 5 ? "a_rather_long_tag_for_a_crop_stage" : "c" + std::to_string(i)}});
  p.push_back(dir.path("out.tif"));
  std::ofstream(dir.path("p.json")) << nlohmann::json{{"pipeline", p}}.dump();
  const auto r = test::run_cli("run --validate " + q(dir.path("p.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // Every row of the table starts its "type" column at the same offset as the header.
  std::istringstream lines(r.out);
  std::string line;
  size_t header_at = std::string::npos, rows = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("  path", 0) == 0) header_at = line.find("type");
    if (line.rfind("  /pipeline/", 0) != 0) continue;
    ASSERT_NE(header_at, std::string::npos) << r.out;
    const std::string type = rows == 0 ? "read" : rows == 12 ? "write" : "crop";
    EXPECT_EQ(line.compare(header_at, type.size() + 1, type + " "), 0) << line << "\n" << r.out;
    ++rows;
  }
  EXPECT_EQ(rows, 13u) << r.out;
}

TEST(CliDocs, PipelinesDocDescribesTheDemoAsItIs) {
  const std::string doc = test::file_bytes(test::data_path("../docs/pipelines.md"));
  EXPECT_EQ(doc.find("as those stages land"), std::string::npos) << "amplify and erode are in the demo already";
  std::ifstream in(test::data_path("pipelines/demo.json"));
  const auto demo = nlohmann::json::parse(in);
  const size_t section = doc.find("## The main job");
  ASSERT_NE(section, std::string::npos);
  const std::string main_job = doc.substr(section, doc.find("\n## ", section + 1) - section);
  for (const auto& st : demo["pipeline"])
    if (st.is_object())
      EXPECT_NE(main_job.find("`" + st["type"].get<std::string>() + "`"), std::string::npos)
          << "docs/pipelines.md's main job does not name stage " << st["type"];
}

// terracl(1) and the bash completion are generated from the command tree the CLI parses with.
TEST(CliDocs, ManPageAndBashCompletionFollowTheCommands) {
  const auto man = test::run_cli("stages --man");
  ASSERT_EQ(man.exit_code, 0) << man.out;
  for (const char* want : {".TH TERRACL 1", ".SS warp", ".SS watershed", "\\-\\-t\\-srs", ".SS studio"})
    EXPECT_NE(man.out.find(want), std::string::npos) << want;
  const auto comp = test::run_cli("stages --bash-completion");
  ASSERT_EQ(comp.exit_code, 0) << comp.out;
  test::TempDir dir;
  const std::string script = dir.path("terracl.bash");
  std::ofstream(script) << comp.out;
  // Completing "terracl wat" gives the command; "terracl warp --t" its options.
  const std::string run = "bash -c 'source " + script + "; COMP_WORDS=(terracl wat); COMP_CWORD=1; _terracl; "
                          "echo \"${COMPREPLY[*]}\"; COMP_WORDS=(terracl warp --t); COMP_CWORD=2; _terracl; "
                          "echo \"${COMPREPLY[*]}\"' > " + dir.path("out.txt") + " 2>&1";
  ASSERT_EQ(std::system(run.c_str()), 0);
  const std::string out = test::file_bytes(dir.path("out.txt"));
  EXPECT_NE(out.find("watershed"), std::string::npos) << out;
  EXPECT_NE(out.find("--t-srs"), std::string::npos) << out;
  EXPECT_NE(out.find("--tr"), std::string::npos) << out;
}
