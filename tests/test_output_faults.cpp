// Outputs that are right or absent: a failed run, a failed write or a failed rename never leaves a
// wrong file under an output's name, and an earlier good file survives it (docs/reliability.md,
// "Outputs: right or absent").
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <terracl/stage.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }
std::string q(const std::string& s) { return "'" + s + "'"; }

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string write_pipeline(const test::TempDir& dir, const std::string& name, const json& p) {
  std::ofstream(dir.path(name), std::ios::binary) << p.dump();
  return dir.path(name);
}

// Anything a writer leaves behind under a temporary name (".NAME.tmpPID-N.ext", ".NAME.input.tif").
bool has_leftover(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.find(".tmp") != std::string::npos || n.find(".input.") != std::string::npos ||
        n.find(".tiles-") != std::string::npos)
      return true;
  }
  return false;
}

}  // namespace

// The tiled drainage of a surface with pits fails (it needs a surface that drains). It used to
// fail after writing its input's elevations under the output's name, over the good result of an
// earlier untiled run.
TEST(OutputFaults, FailedTiledRunKeepsTheEarlierOutput) {
  test::TempDir dir;
  const std::string p = write_pipeline(dir, "p.json", json::array({crop(), dir.path("c.tif"), "drainage", dir.path("acc.tif")}));
  const auto good = test::run_cli("run -q " + q(p));
  ASSERT_EQ(good.exit_code, 0) << good.out;
  const std::string before = file_bytes(dir.path("acc.tif"));
  const auto r = test::run_cli("run -q " + q(p) + " --tile 32");
  ASSERT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("no lower neighbour"), std::string::npos) << r.out;
  EXPECT_EQ(file_bytes(dir.path("acc.tif")), before) << "the failed run replaced acc.tif";
  EXPECT_FALSE(has_leftover(dir.dir()));
  // With no earlier file, a failed run leaves none.
  fs::remove(dir.path("acc.tif"));
  EXPECT_EQ(test::run_cli("run -q " + q(p) + " --tile 32").exit_code, 1);
  EXPECT_FALSE(fs::exists(dir.path("acc.tif")));
  EXPECT_FALSE(has_leftover(dir.dir()));
}
