// SPDX-License-Identifier: Apache-2.0
// Outputs that are right or absent: a failed run, a failed write or a failed rename never leaves a
// wrong file under an output's name, and an earlier good file survives it (docs/reliability.md,
// "Outputs: right or absent").
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }
std::string q(const std::string& s) { return "'" + s + "'"; }

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
  const std::string p =
      write_pipeline(dir, "p.json", json::array({crop(), dir.path("c.tif"), "drainage", dir.path("acc.tif")}));
  const auto good = test::run_cli("run -q " + q(p));
  ASSERT_EQ(good.exit_code, 0) << good.out;
  const std::string before = test::file_bytes(dir.path("acc.tif"));
  const auto r = test::run_cli("run -q " + q(p) + " --tile 32");
  ASSERT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("no lower neighbour"), std::string::npos) << r.out;
  EXPECT_EQ(test::file_bytes(dir.path("acc.tif")), before) << "the failed run replaced acc.tif";
  EXPECT_FALSE(has_leftover(dir.dir()));
  // With no earlier file, a failed run leaves none.
  fs::remove(dir.path("acc.tif"));
  EXPECT_EQ(test::run_cli("run -q " + q(p) + " --tile 32").exit_code, 1);
  EXPECT_FALSE(fs::exists(dir.path("acc.tif")));
  EXPECT_FALSE(has_leftover(dir.dir()));
}

// A NUL ends the name at the system call: "o\u0000x.tif" wrote a file named "o". Names with
// control characters are refused before anything runs, naming the pipeline field.
TEST(OutputFaults, ControlCharactersInAPipelineFileNameAreRefused) {
  test::TempDir dir;
  for (const std::string bad : {std::string("o\0x.tif", 7), std::string("a\x01b.tif")}) {
    const std::string p = write_pipeline(dir, "p.json", json::array({crop(), dir.path(bad)}));
    const auto r = test::run_cli("run -q " + q(p));
    EXPECT_EQ(r.exit_code, 2) << r.out;
    EXPECT_NE(r.out.find("/1/filename"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("control characters"), std::string::npos) << r.out;
    EXPECT_EQ(dir.count(), 1u) << "only the pipeline file";
  }
  const std::string p = write_pipeline(dir, "p.json", json::array({crop() + std::string("\0", 1), dir.path("o.tif")}));
  const auto r = test::run_cli("run -q " + q(p));
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("NUL at byte"), std::string::npos) << r.out;
}

// A tiled run killed part way and resumed writes an output of about the size of a straight run
// (it was several times larger: blocks of the reopened partial file were rewritten, not reused).
TEST(OutputFaults, ResumedTiledOutputIsAboutTheSizeOfAStraightRun) {
  test::TempDir dir;
  const std::string p = write_pipeline(dir, "p.json", json::array({crop(), dir.path("o.tif")}));
  ASSERT_EQ(test::run_cli("run -q " + q(p) + " --tile 16").exit_code, 0);
  const auto straight = fs::file_size(dir.path("o.tif"));
  fs::remove(dir.path("o.tif"));
  setenv("TERRACL_TEST_KILL_AFTER_TILES", "20", 1);
  const auto killed = test::run_cli("run -q " + q(p) + " --tile 16 --resume");
  unsetenv("TERRACL_TEST_KILL_AFTER_TILES");
  ASSERT_NE(killed.exit_code, 0) << killed.out;
  ASSERT_FALSE(fs::exists(dir.path("o.tif")));
  const auto resumed = test::run_cli("run -q " + q(p) + " --tile 16 --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  const auto size = fs::file_size(dir.path("o.tif"));
  EXPECT_LE(double(size), 1.5 * double(straight)) << "resumed " << size << " bytes, straight " << straight;
  EXPECT_EQ(read_heightfield(dir.path("o.tif")).z, read_heightfield(crop()).z);
}

namespace {

std::string convert(const std::string& in, const std::string& out) {
  const auto r = test::run_cli("convert -q " + q(in) + " " + q(out));
  EXPECT_EQ(r.exit_code, 0) << r.out;
  return r.out;
}

}  // namespace

// An image beside a sidecar written for another image (a failed rename between the two, or a
// file copied over) is refused, naming both files; a sidecar from before the check still reads.
TEST(OutputFaults, SidecarOfAnotherImageIsRefused) {
  test::TempDir dir;
  for (const std::string ext : {"png", "npy", "r16"}) {
    const std::string a = dir.path("a." + ext), b = dir.path("b." + ext);
    convert(crop(), a);
    // Same size, one cell raised by 100 m: only the bytes tell the two apart.
    Heightfield h = read_heightfield(crop());
    h.z[h.width * 10 + 10] += 100.0f;
    write_heightfield(h, b);
    const json sc = json::parse(test::file_bytes(a + ".json"));
    ASSERT_TRUE(sc.contains("image_bytes") && sc.contains("image_fnv1a64")) << sc.dump();
    fs::copy_file(b, a, fs::copy_options::overwrite_existing);
    const auto r = test::run_cli("convert -q " + q(a) + " " + q(dir.path("z.tif")));
    EXPECT_EQ(r.exit_code, 1) << ext << "\n" << r.out;
    EXPECT_NE(r.out.find("do not belong together"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(a + " and its sidecar " + a + ".json"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir.path("z.tif")));
    // A sidecar without the two fields (written before them) is read as before.
    json old = sc;
    old.erase("image_bytes");
    old.erase("image_fnv1a64");
    std::ofstream(a + ".json") << old.dump(2);
    const auto o = test::run_cli("convert -q " + q(a) + " " + q(dir.path("z.tif")));
    EXPECT_EQ(o.exit_code, 0) << ext << "\n" << o.out;
    fs::remove(dir.path("z.tif"));
  }
  // Gradient images carry their scale m in the sidecar: the same check.
  GradientField g(16, 16), g2(16, 16);
  for (size_t i = 0; i < g.size(); ++i) g.gx[i] = 0.1f * float(i % 7), g2.gx[i] = 0.3f * float(i % 5);
  write_gradient_image(g, dir.path("g.png"));
  write_gradient_image(g2, dir.path("g2.png"));
  EXPECT_NO_THROW(read_gradient_image(dir.path("g.png")));
  fs::copy_file(dir.path("g2.png"), dir.path("g.png"), fs::copy_options::overwrite_existing);
  try {
    read_gradient_image(dir.path("g.png"));
    ADD_FAILURE() << "a gradient image beside another image's sidecar was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("do not belong together"), std::string::npos) << e.what();
  }
}

namespace {

// strace can inject syscall errors only where ptrace is allowed (CI containers may forbid it).
bool strace_works() {
  if (!fs::exists("/usr/bin/strace")) return false;
  return std::system("/usr/bin/strace -f -o /dev/null true >/dev/null 2>&1") == 0;
}

// `terracl -q ARGS` with `fault` (strace's inject=) applied to every process of the run.
test::CmdResult run_with_fault(const std::string& fault, const std::string& args) {
  const std::string cmd =
      "/usr/bin/strace -f -o /dev/null -e inject=" + fault + " " + std::string(TERRACL_CLI) + " -q " + args + " 2>&1";
  test::CmdResult r{-1, ""};
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool has_temporary(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) return true;
  return false;
}

}  // namespace

// A full disk (ENOSPC on a write) or a failed rename (EIO) while writing each output format: exit
// 1, a message naming the output (never its temporary) and the reason, no temporary left, and the
// earlier output byte for byte. With -q, the output's own writes are the run's first.
class OutputFaultsFormat : public ::testing::TestWithParam<std::string> {};

TEST_P(OutputFaultsFormat, InjectedWriteAndRenameErrorsLeaveRightOrAbsentOutputs) {
  // scripts/install-deps.sh installs strace: a machine that runs the suite can inject faults.
  ASSERT_TRUE(strace_works()) << "strace is missing or ptrace is forbidden (strace -f true failed)";
  test::TempDir dir;
  const std::string newer = test::data_path("crops/frontrange_64.asc");
  const std::string ext = GetParam();
  const std::string out = dir.path("out." + ext), sc = out + ".json";
  const bool sidecar = ext == "png" || ext == "npy" || ext == "r16";
  convert(crop(), out);
  const std::string before = test::file_bytes(out), sc_before = sidecar ? test::file_bytes(sc) : "";
  struct Fault {
    std::string inject, reason;
  };
  std::vector<Fault> faults{{"write:error=ENOSPC:when=1", "No space left on device"},
                            {"rename:error=EIO:when=1", "Input/output error"}};
  if (sidecar) faults.push_back({"write:error=ENOSPC:when=2", "No space left on device"});
  for (const Fault& f : faults) {
    const std::string what = ext + " " + f.inject;
    const auto r = run_with_fault(f.inject, "convert " + q(newer) + " " + q(out));
    EXPECT_EQ(r.exit_code, 1) << what << "\n" << r.out;
    EXPECT_NE(r.out.find(f.reason), std::string::npos) << what << "\n" << r.out;
    EXPECT_NE(r.out.find(out), std::string::npos) << what << ": names the output\n" << r.out;
    EXPECT_EQ(r.out.find(".tmp"), std::string::npos) << what << ": names a temporary\n" << r.out;
    EXPECT_EQ(test::file_bytes(out), before) << what << ": the earlier output changed";
    if (sidecar) EXPECT_EQ(test::file_bytes(sc), sc_before) << what << ": the earlier sidecar changed";
    EXPECT_FALSE(has_temporary(dir.dir())) << what;
  }
  if (sidecar) {
    // The sidecar's rename fails after the image's: the new image stands beside the old sidecar,
    // and reading the pair is refused rather than decoded with the old range.
    const auto r = run_with_fault("rename:error=EIO:when=2", "convert " + q(newer) + " " + q(out));
    EXPECT_EQ(r.exit_code, 1) << ext << "\n" << r.out;
    EXPECT_NE(r.out.find(sc), std::string::npos) << r.out;
    const auto read = test::run_cli("convert -q " + q(out) + " " + q(dir.path("z.tif")));
    EXPECT_EQ(read.exit_code, 1) << ext << "\n" << read.out;
    EXPECT_NE(read.out.find("belong"), std::string::npos) << read.out;
    EXPECT_FALSE(has_temporary(dir.dir())) << ext;
  }
  // And with no earlier file: none afterwards.
  fs::remove(out);
  fs::remove(sc);
  const auto r = run_with_fault("write:error=ENOSPC:when=1", "convert " + q(newer) + " " + q(out));
  EXPECT_EQ(r.exit_code, 1) << ext << "\n" << r.out;
  EXPECT_FALSE(fs::exists(out)) << ext;
  EXPECT_FALSE(fs::exists(sc)) << ext;
}

INSTANTIATE_TEST_SUITE_P(OutputFaults, OutputFaultsFormat, ::testing::Values("tif", "png", "exr", "npy", "r16"),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param; });

// A GDAL format of several files (.asc + .prj + .asc.aux.xml): a full disk on any of its writes
// gives the whole set or nothing. AAIGrid does not check its .prj's write, nor GDAL its .aux.xml's:
// an output without its CRS used to be kept, and the empty temporary .prj left beside it.
TEST(OutputFaults, AMultiFileGdalOutputIsWholeOrAbsentOnAFullDisk) {
  ASSERT_TRUE(strace_works()) << "strace is missing or ptrace is forbidden (strace -f true failed)";
  test::TempDir dir;
  const std::string in = test::data_path("crops/frontrange_64.asc"), out = dir.path("o.asc");
  int failed = 0, written = 0;
  for (int n = 1; n <= 10; ++n) {
    for (const char* f : {"o.asc", "o.prj", "o.asc.aux.xml"}) fs::remove(dir.path(f));
    const auto r = run_with_fault("write:error=ENOSPC:when=" + std::to_string(n), "convert " + q(in) + " " + q(out));
    EXPECT_FALSE(has_temporary(dir.dir())) << "write " << n;
    if (r.exit_code == 0) {
      ++written;
      for (const char* f : {"o.asc", "o.prj", "o.asc.aux.xml"})
        EXPECT_GT(fs::file_size(dir.path(f)), 0u) << f << ", write " << n;
      EXPECT_FALSE(read_heightfield(out).georef.crs_wkt.empty()) << "write " << n;
    } else {
      ++failed;
      EXPECT_EQ(r.exit_code, 1) << r.out;
      EXPECT_NE(r.out.find(out), std::string::npos) << "write " << n << ": names the output\n" << r.out;
      for (const char* f : {"o.asc", "o.prj", "o.asc.aux.xml"}) EXPECT_FALSE(fs::exists(dir.path(f))) << f << ", write " << n;
    }
  }
  EXPECT_GE(failed, 8) << "the .asc's, the .prj's and the .aux.xml's writes each fail the output";
  EXPECT_GE(written, 1) << "writes after the output's own are not the output's";
}

// The other writers on a full disk: a rendered picture, meshes, a metrics report.
TEST(OutputFaults, InjectedWriteErrorsFailTheOtherWriters) {
  // scripts/install-deps.sh installs strace: a machine that runs the suite can inject faults.
  ASSERT_TRUE(strace_works()) << "strace is missing or ptrace is forbidden (strace -f true failed)";
  test::TempDir dir;
  for (const std::string args : {"render " + q(crop()) + " -o " + q(dir.path("r.png")),
                                 "render " + q(crop()) + " -o " + q(dir.path("r.tif")),
                                 "mesh " + q(crop()) + " -o " + q(dir.path("m.glb")),
                                 "mesh " + q(crop()) + " -o " + q(dir.path("m.obj")),
                                 "metrics " + q(crop()) + " --json " + q(dir.path("m.json"))}) {
    // The first write() must be the output's, not a kernel cache's: a run without the fault fills
    // the caches first, and terracl's program cache (written on PoCL with TERRACL_PROGRAM_CACHE=1)
    // spares PoCL the temporary files it writes when it builds from source.
    setenv("TERRACL_PROGRAM_CACHE", "1", 1);
    const auto warm = test::run_cli("-q " + args);
    ASSERT_EQ(warm.exit_code, 0) << args << "\n" << warm.out;
    for (const auto& e : fs::directory_iterator(dir.dir())) fs::remove(e.path());
    const auto r = run_with_fault("write:error=ENOSPC:when=1", args);
    unsetenv("TERRACL_PROGRAM_CACHE");
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("No space left on device"), std::string::npos) << args << "\n" << r.out;
    EXPECT_EQ(r.out.find(".tmp"), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_EQ(dir.count(), 0u) << "nothing may be left";
}
