// SPDX-License-Identifier: Apache-2.0
// Hostile input and interrupted runs, run as a careless or hostile user would: every
// case here crashed, hung, destroyed data, wrapped a number or gave an unhelpful message before.
// Each test states the exit code and the words of the message it expects, and that nothing
// partial (or nothing at all) was written.
#include <OpenImageIO/imageio.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/stage.hpp>

#include "test_helpers.hpp"

using namespace terracl;
namespace fs = std::filesystem;

namespace {

std::string crop() { return test::data_path("crops/presidential_128x96.tif"); }
std::string q(const std::string& s) { return "'" + s + "'"; }

std::string write_text(const test::TempDir& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir.path(name), std::ios::binary) << text;
  return dir.path(name);
}

std::string deep_json(size_t n) { return std::string(n, '[') + std::string(n, ']'); }

bool has_temporary(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) return true;
  return false;
}

// A usage or run error with our prefix, never a crash, an "internal:" error or an echo of a
// huge value.
void expect_clean_error(const test::CmdResult& r, int code, const std::string& words, const std::string& what) {
  EXPECT_EQ(r.exit_code, code) << what << "\n" << r.out.substr(0, 2000);
  EXPECT_NE(r.out.find("terracl ERROR: "), std::string::npos) << what << "\n" << r.out.substr(0, 2000);
  EXPECT_NE(r.out.find(words), std::string::npos) << what << "\n" << r.out.substr(0, 2000);
  EXPECT_EQ(r.out.find("internal:"), std::string::npos) << what << "\n" << r.out.substr(0, 2000);
  EXPECT_LT(r.out.size(), 2000u) << what << ": the message echoes the bad value";
}

}  // namespace

// --- 1. crashes and hangs ------------------------------------------------------------------------

TEST(Reliability, CropWindowPastIntMaxIsAnErrorNotACrash) {
  test::TempDir dir;
  const auto r = test::run_cli("crop -q " + q(crop()) + " -o " + q(dir.path("c.tif")) + " --x 2147483647 --width 2 --height 2");
  expect_clean_error(r, 1, "does not fit in the 128 x 96 raster", "crop --x 2147483647");
  // The pipeline form passes --validate (the raster's size is not known yet) and fails cleanly at run time.
  const std::string p = write_text(
      dir, "crop.json",
      json::array({crop(), json{{"type", "crop"}, {"x", 2147483647}, {"width", 2}, {"height", 2}}, dir.path("o.tif")}).dump());
  const auto v = test::run_cli("run -q " + q(p));
  expect_clean_error(v, 1, "does not fit", "pipeline crop x 2147483647");
  // Past int32 the option itself is out of range.
  const auto big = test::run_cli("crop -q " + q(crop()) + " -o " + q(dir.path("c.tif")) + " --x 2147483648 --width 2");
  expect_clean_error(big, 2, "out of range", "crop --x 2147483648");
  EXPECT_EQ(dir.count(), 1u) << "nothing but the pipeline file may be left";
}

TEST(Reliability, ErodeRegionFeatherOutOfRangeIsRefusedAtOnce) {
  test::TempDir dir;
  for (const std::string f : {"1e9", "100000", "-1"}) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = test::run_cli("erode -q " + q(crop()) + " -o " + q(dir.path("e.tif")) + " --region " + q(crop()) +
                                 " --region-feather " + f + " --steps 2");
    expect_clean_error(r, 2, "/region_feather", "--region-feather " + f);
    EXPECT_NE(r.out.find("out of range"), std::string::npos) << r.out;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0) << f;
  }
  EXPECT_EQ(dir.count(), 0u);
}

TEST(Reliability, DeeplyNestedJsonIsRefusedEverywhere) {
  test::TempDir dir;
  const std::string deep = write_text(dir, "deep.json", deep_json(100000));
  for (const std::string flag : {"--validate", "--print-resolved", ""}) {
    const auto r = test::run_cli("run -q " + q(deep) + " " + flag);
    expect_clean_error(r, 2, "nested deeper than 64 levels", "run " + flag);
    EXPECT_NE(r.out.find(deep), std::string::npos) << "names the file\n" << r.out;
  }
  const auto e = test::run_cli("edit -q flat:33x33 --script " + q(deep) + " -o " + q(dir.path("x.tif")));
  expect_clean_error(e, 1, "nested deeper than 64 levels", "edit --script");
  // An edit stage naming such a script: refused when the stage runs, with the pipeline path.
  const std::string p = dir.path("p.json");
  std::ofstream(p) << json::array({crop(), json{{"type", "edit"}, {"script", deep}}, dir.path("o.tif")}).dump();
  const auto s = test::run_cli("run -q " + q(p));
  expect_clean_error(s, 1, "nested deeper than 64 levels", "edit stage");
  EXPECT_FALSE(fs::exists(dir.path("o.tif")));
  EXPECT_FALSE(fs::exists(dir.path("x.tif")));
  // Just inside the limit parses (the limit is documented, not accidental).
  EXPECT_NO_THROW(parse_json_limited(deep_json(max_json_depth), "test", "inline"));
  EXPECT_THROW(parse_json_limited(deep_json(max_json_depth + 1), "test", "inline"), Error);
}

TEST(Reliability, EditOfAHugeFlatBaseIsRefusedBeforeAllocating) {
  test::TempDir dir;
  const std::string script = write_text(dir, "s.json", R"([{"op": "scale_slopes", "factor": 2}])");
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = test::run_cli("edit -q flat:60000x60000 --script " + q(script) + " -o " + q(dir.path("x.tif")));
  expect_clean_error(r, 1, "needs about", "edit flat:60000x60000");
  EXPECT_NE(r.out.find("use a smaller base"), std::string::npos) << r.out;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 30.0);
  // The same refusal under a memory cap the user sets.
  const std::string env_cmd = "env TERRACL_MAX_MEMORY=64M " + std::string(TERRACL_CLI) + " edit -q flat:2000x2000 --script " +
                              q(script) + " -o " + q(dir.path("z.tif")) + " 2>&1";
  FILE* pipe = popen(env_cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  EXPECT_NE(out.find("TERRACL_MAX_MEMORY"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir.path("z.tif")));
  // Erosion and reconstruction check too, before they allocate.
  for (const std::string& args :
       {"erode -q " + q(crop()) + " -o " + q(dir.path("e.tif")) + " --steps 1",
        "reconstruct -q --gradient " + q(dir.path("g.exr")) + " -o " + q(dir.path("r.tif"))}) {
    if (args.rfind("reconstruct", 0) == 0) write_gradient(GradientField(128, 96), dir.path("g.exr"));
    // 250 KiB: enough to read the 128 x 96 input (the readers check too), not to run the stage.
    const std::string cmd = "env TERRACL_MAX_MEMORY=250K " + std::string(TERRACL_CLI) + " " + args + " 2>&1";
    FILE* p2 = popen(cmd.c_str(), "r");
    std::string o2;
    while ((n = fread(buf, 1, sizeof buf, p2)) > 0) o2.append(buf, n);
    EXPECT_EQ(WEXITSTATUS(pclose(p2)), 1) << o2;
    EXPECT_NE(o2.find("128 x 96"), std::string::npos) << o2;
    EXPECT_NE(o2.find("needs about"), std::string::npos) << o2;
    EXPECT_NE(o2.find(args.substr(0, args.find(' ')) + ": "), std::string::npos) << "the stage's own check\n" << o2;
  }
  EXPECT_FALSE(fs::exists(dir.path("e.tif")));
  EXPECT_FALSE(fs::exists(dir.path("r.tif")));
}

// --- 2. data destroyed -------------------------------------------------------------------------

TEST(Reliability, OutputsNeverAliasInputsOrEachOther) {
  test::TempDir dir;
  const std::string a = dir.path("a.tif");
  fs::copy_file(crop(), a);
  const std::string before = test::file_bytes(a);
  const std::string script = write_text(dir, "s.json", R"([{"op": "scale_slopes", "factor": 2}])");
  struct Case {
    std::string args, words;
  };
  const std::vector<Case> cases = {
      {"metrics -q " + q(a) + " --json " + q(a), "--json " + a + ": is also an input"},
      {"render -q " + q(a) + " -o " + q(a), "is also an input"},
      {"erode -q " + q(a) + " -o " + q(dir.path("o.tif")) + " --delta " + q(a), "--delta " + a + ": is also an input"},
      {"erode -q " + q(a) + " -o " + q(dir.path("o.tif")) + " --water " + q(dir.path("o.tif")),
       ": is also written by -o"},
      {"erode -q " + q(a) + " -o " + q(dir.path("./o.tif")) + " --sediment " + q(dir.path("x/../o.tif")),
       "is also written by"},
      {"edit -q " + q(a) + " --script " + q(script) + " -o " + q(dir.path("e.tif")) + " --preview " +
           q(dir.path("e.tif")),
       "--preview " + dir.path("e.tif") + ": is also written by -o"},
      {"edit -q " + q(a) + " --script " + q(script) + " -o " + q(a), "-o " + a + ": is also an input (BASE)"},
      {"convert -q " + q(a) + " " + q(a), "is also an input"},
  };
  fs::create_directories(dir.path("x"));
  for (const auto& c : cases) expect_clean_error(test::run_cli(c.args), 2, c.words, c.args);
  EXPECT_EQ(test::file_bytes(a), before) << "the input was changed";
  EXPECT_FALSE(fs::exists(dir.path("o.tif")));
  EXPECT_FALSE(fs::exists(dir.path("e.tif")));
}

TEST(Reliability, OutputsNeverReplaceDevicesOrFolders) {
  test::TempDir dir;
  fs::create_directories(dir.path("folder.tif"));
  // A FIFO stands for a device: a rename onto it replaces it with a regular file.
  ASSERT_EQ(::mkfifo(dir.path("fifo.json").c_str(), 0600), 0);
  for (const std::string& args :
       {"metrics -q " + q(crop()) + " --json " + q(dir.path("fifo.json")),
        "convert -q " + q(crop()) + " " + q(dir.path("folder.tif")),
        "erode -q " + q(crop()) + " -o " + q(dir.path("folder.tif")) + " --steps 1",
        "metrics -q " + q(crop()) + " --json /dev/null"})
    expect_clean_error(test::run_cli(args), 2, "is not a regular file", args);
  struct stat st {};
  ASSERT_EQ(::stat(dir.path("fifo.json").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced";
  EXPECT_TRUE(fs::is_directory(dir.path("folder.tif")));
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  // Pipelines make the same check.
  std::ofstream(dir.path("p2.json")) << json::array({crop(), json{{"type", "metrics"}, {"json", dir.path("fifo.json")}}, dir.path("o.tif")}).dump();
  expect_clean_error(test::run_cli("run --validate " + q(dir.path("p2.json"))), 2, "is not a regular file", "pipeline");
}

// --- 3. temporary files ------------------------------------------------------------------------

TEST(Reliability, SignalHandlerUnlinksRegisteredTemporaries) {
  test::TempDir dir;
  const std::string tmp = temporary_path_for(dir.path("out.tif"));
  std::ofstream(tmp) << "partial";
  const std::string done = temporary_path_for(dir.path("done.tif"));
  std::ofstream(done) << "complete";
  commit_temporary(done, dir.path("done.tif"));
  ASSERT_TRUE(fs::exists(tmp));
  remove_temporaries_signal_safe();
  EXPECT_FALSE(fs::exists(tmp)) << "a registered temporary survived";
  EXPECT_TRUE(fs::exists(dir.path("done.tif"))) << "a committed output was removed";
}

namespace {

// The CLI started with `args`, its stdout and stderr on one pipe (read end returned in `out_fd`).
pid_t spawn_cli(const std::vector<std::string>& args, int& out_fd) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    ::dup2(fds[1], 1);
    ::dup2(fds[1], 2);
    ::close(fds[0]);
    ::close(fds[1]);
    std::vector<char*> argv{const_cast<char*>(TERRACL_CLI)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(TERRACL_CLI, argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  out_fd = fds[0];
  return pid;
}

// Reads the child's output until it contains `words` (true) or the child closes it (false).
// A condition, not a sleep: under load (20 on 2 cores) a fixed sleep fired before the work began.
bool wait_for_output(int fd, const std::string& words, std::string& seen) {
  char buf[4096];
  while (seen.find(words) == std::string::npos) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) return false;
    seen.append(buf, size_t(n));
  }
  return true;
}

// Polls `dir` until a temporary output (.NAME.tmpPID-N.ext) appears, up to `seconds`.
bool wait_for_temporary(const fs::path& dir, double seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
    if (has_temporary(dir)) return true;
    ::usleep(2000);
  }
  return false;
}

// Reads the child's output to the end (into `seen` when given) and reaps it.
int wait_exit(pid_t pid, int fd, std::string* seen = nullptr) {
  char buf[4096];
  for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;)
    if (seen) seen->append(buf, size_t(n));
  ::close(fd);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

}  // namespace

TEST(Reliability, SigtermStopsWithExit143AndLeavesNoTemporary) {
  test::TempDir dir;
  const std::string out = dir.path("e.tif");
  int fd = -1;
  const pid_t pid = spawn_cli({"--progress", "json", "erode", crop(), "-o", out, "--steps", "100000000", "--delta",
                               dir.path("d.exr")},
                              fd);
  ASSERT_GT(pid, 0);
  std::string seen;
  // Signalled once the simulation runs (its first step reported), whatever the machine's load.
  ASSERT_TRUE(wait_for_output(fd, "step ", seen)) << seen;
  ::kill(pid, SIGTERM);
  EXPECT_EQ(wait_exit(pid, fd), 128 + SIGTERM) << seen;
  EXPECT_FALSE(has_temporary(dir.dir()));
  EXPECT_FALSE(fs::exists(out));
}

// The end-to-end form of SignalHandlerUnlinksRegisteredTemporaries: the CLI is stopped while it
// writes (an LZMA GeoTIFF of a 1201^2 DEM: seconds of compression inside GDAL), by one Ctrl-C and
// by SIGTERM; the temporary it was writing must be gone and the output must not exist. One Ctrl-C
// is enough: GDAL's progress callback between the blocks it compresses sees the interrupt flag
// (before, GDAL finished the write and the CLI exited 0 with a whole output). SIGTERM (and a
// second Ctrl-C, the same handler) unlinks the registered temporary from the signal handler.
TEST(Reliability, SignalsDuringAWriteLeaveNoTemporary) {
  for (const int sig : {SIGINT, SIGTERM}) {
    test::TempDir dir;
    const std::string out = dir.path("slow.tif");
    int fd = -1;
    const pid_t pid = spawn_cli({"convert", "-q", test::data_path("dem/N44W072.hgt"), out, "--co", "COMPRESS=LZMA", "--co",
                                 "LZMA_PRESET=9", "--co", "PREDICTOR=3", "--ot", "Float32"},
                                fd);
    ASSERT_GT(pid, 0);
    const bool writing = wait_for_temporary(dir.dir(), 120);
    ASSERT_TRUE(writing) << "the write never started";
    ::kill(pid, sig);
    std::string seen;
    const int code = wait_exit(pid, fd, &seen);
    EXPECT_EQ(code, sig == SIGINT ? 130 : 143) << strsignal(sig) << "\n" << seen;
    if (sig == SIGINT) EXPECT_NE(seen.find("write was stopped"), std::string::npos) << seen;
    EXPECT_FALSE(has_temporary(dir.dir())) << strsignal(sig) << ": a temporary was left";
    EXPECT_FALSE(fs::exists(out)) << strsignal(sig);
  }
}

TEST(Reliability, FailedRenameSaysWhyNotSuccess) {
  test::TempDir dir;
  const std::string tmp = temporary_path_for(dir.path("x.tif"));
  std::ofstream(tmp) << "data";
  try {
    commit_temporary(tmp, dir.path("missing/x.tif"));
    FAIL() << "rename into a missing folder succeeded";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("Success"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(tmp));
}

// --- 4. numbers and messages -------------------------------------------------------------------

TEST(Reliability, NumbersThatWouldWrapAreRefused) {
  test::TempDir dir;
  const std::string o = " -o " + q(dir.path("o.tif"));
  const std::string in = q(crop());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"amplify -q " + in + o + " --dictionary " + in + " --factor 4294967300", "amplify/factor"},
      {"amplify -q " + in + o + " --dictionary " + in + " --factor 1024", "amplify/factor"},
      {"amplify -q " + in + o + " --dictionary " + in + " --trees -3", "amplify/trees"},
      {"amplify -q " + in + o + " --dictionary " + in + " --checks -5", "amplify/checks"},
      {"amplify -q " + in + o + " --dictionary " + in + " --style-blend -1", "amplify/style_blend"},
      {"amplify -q " + in + o + " --dictionary " + in + " --detail-gain 1e30", "amplify/detail_gain"},
      {"erode -q " + in + o + " --steps 4294967297", "erode/steps"},
      {"erode -q " + in + o + " --steps 1e12", "erode/steps"},
      {"erode -q " + in + o + " --steps -3", "erode/steps"},
      {"downsample -q " + in + o + " --factor 9223372036854775807", "downsample/factor"},
  };
  for (const auto& [args, path] : cases) {
    const auto r = test::run_cli(args);
    expect_clean_error(r, 2, path + ": ", args);
    EXPECT_NE(r.out.find("out of range"), std::string::npos) << args << "\n" << r.out;
    EXPECT_EQ(r.out.find("-727379968"), std::string::npos) << r.out;
  }
  // The same in a pipeline, caught by --validate.
  for (const json& v : {json(9223372036854775807LL), json(2e300), json(-1)}) {
    std::ofstream(dir.path("p.json")) << json::array({crop(), json{{"type", "downsample"}, {"factor", v}}, dir.path("o.tif")}).dump();
    expect_clean_error(test::run_cli("run --validate " + q(dir.path("p.json"))), 2, "/1/factor: ", v.dump());
  }
  EXPECT_EQ(dir.count(), 1u);
}

TEST(Reliability, ValidateCatchesNullsAndRanges) {
  test::TempDir dir;
  std::ofstream(dir.path("p.json")) << R"([")" << crop() << R"(", {"type": "erode", "rain": null}, ")" << dir.path("o.tif") << R"("])";
  const auto r = test::run_cli("run --validate " + q(dir.path("p.json")));
  // (erode's steps has no default since the default run is 400 s of simulated time: rain then.)
  expect_clean_error(r, 2, "/1/rain: null is not a value", "rain null");
  std::ofstream(dir.path("q.json")) << json::array({crop(), json{{"type", "erode"}, {"steps", -4}}, dir.path("o.tif")}).dump();
  expect_clean_error(test::run_cli("run --validate " + q(dir.path("q.json"))), 2, "/1/steps: -4 is out of range", "steps -4");
  // 1e400 does not fit a double: an error naming the file, not json.exception.out_of_range.
  std::ofstream(dir.path("n.json")) << R"([")" << crop() << R"(", {"type": "erode", "steps": 1e400}, "o.tif"])";
  const auto n = test::run_cli("run --validate " + q(dir.path("n.json")));
  expect_clean_error(n, 2, dir.path("n.json") + ": a number in the JSON is out of range", "1e400");
}

TEST(Reliability, OverlongNamesAndNumbersGiveClearErrors) {
  test::TempDir dir;
  const std::string long_name = dir.path(std::string(5000, 'a') + ".tif");
  expect_clean_error(test::run_cli("convert -q " + q(crop()) + " " + q(long_name)), 2, "file name too long", "5000 chars");
  std::ofstream(dir.path("p.json")) << json::array({crop(), long_name}).dump();
  expect_clean_error(test::run_cli("run --validate " + q(dir.path("p.json"))), 2, "file name too long", "pipeline");
  const std::string script = write_text(dir, "s.json", R"([{"op": "scale_slopes", "factor": 2}])");
  for (const std::string& spec : std::vector<std::string>{"flat:99999999999999999999999x4", "flat:4x4@1" + std::string(400, '0'),
                                                         "flat:4x4@1e999"})
    expect_clean_error(test::run_cli("edit -q " + q(spec) + " --script " + q(script) + " -o " + q(dir.path("x.tif"))), 2,
                       "size must be 2..65536", spec);
  expect_clean_error(test::run_cli("--device 99999999999999999999999 info " + q(crop())), 2, "out of range", "--device");
  // Input names longer than the file system allows (ENAMETOOLONG): std::filesystem::exists throws
  // there, which stopped the edit-script fuzzer and read "internal: filesystem error" in the CLI.
  const std::string long_input = std::string(300, 'b') + ".tif";
  const std::string paste = write_text(
      dir, "paste.json", R"({"units": "cells", "operations": [{"op": "copy_paste", "source": ")" + long_input + R"("}]})");
  expect_clean_error(test::run_cli("edit -q flat:64x64 --script " + q(paste) + " -o " + q(dir.path("x.tif"))), 1,
                     "/operations/0/source: file", "copy_paste source name too long");
  expect_clean_error(test::run_cli("edit -q " + q(dir.path(long_input)) + " --script " + q(script) + " -o " +
                                   q(dir.path("x.tif"))),
                     2, "file name too long", "edit base name too long");
  EXPECT_FALSE(fs::exists(dir.path("x.tif")));
}

TEST(Reliability, DownsampleErrorsNameDownsample) {
  test::TempDir dir;
  const auto r = test::run_cli("downsample -q " + q(crop()) + " -o " + q(dir.path("d.tif")) + " --factor 200");
  expect_clean_error(r, 1, "terracl ERROR: downsample: a 128 x 96 raster has no complete 200 x 200 block", "factor 200");
  EXPECT_EQ(r.out.find("amplify"), std::string::npos) << r.out;
}

// --- 5. sizes checked before allocating ----------------------------------------------------------

namespace {
uint32_t crc32_png(const unsigned char* p, size_t n) {
  uint32_t c = 0xffffffffu;
  for (size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}
void put32(std::string& s, uint32_t v) {
  for (int i = 3; i >= 0; --i) s += char((v >> (8 * i)) & 0xff);
}
// A PNG whose header claims w x h 16-bit grey cells, with no pixel data.
std::string png_header_only(uint32_t w, uint32_t h) {
  std::string s = "\x89PNG\r\n\x1a\n";
  std::string ihdr = "IHDR";
  put32(ihdr, w);
  put32(ihdr, h);
  ihdr += std::string("\x10\x00\x00\x00\x00", 5);
  put32(s, 13);
  s += ihdr;
  put32(s, crc32_png(reinterpret_cast<const unsigned char*>(ihdr.data()), ihdr.size()));
  put32(s, 0);  // an empty IDAT: libpng stops reading the header there
  s += "IDAT";
  put32(s, crc32_png(reinterpret_cast<const unsigned char*>("IDAT"), 4));
  put32(s, 0);
  s += "IEND";
  put32(s, crc32_png(reinterpret_cast<const unsigned char*>("IEND"), 4));
  return s;
}
}  // namespace

TEST(Reliability, RasterHeadersClaimingHugeSizesAreRefusedBeforeAllocating) {
  test::TempDir dir;
  const std::string png = write_text(dir, "huge.png", png_header_only(100000, 100000));
  std::ofstream(dir.path("huge.png.json")) << R"({"zmin": 0, "zmax": 1000, "cell_x": 1, "cell_y": 1})";
  const auto r = test::run_cli("info " + q(png));
  expect_clean_error(r, 1, "100000 x 100000 cells; each side may be at most 65536", "PNG 100000^2");
  // A GeoTIFF claiming 10^6 x 10^6 float cells (sparse: 180 KB on disk) was std::bad_alloc.
  const std::string tif = dir.path("huge.tif");
  ASSERT_EQ(std::system(("gdal_create -q -of GTiff -outsize 1000000 1000000 -ot Float32 -co SPARSE_OK=TRUE -co TILED=YES "
                         "-co BIGTIFF=YES -co BLOCKXSIZE=8192 -co BLOCKYSIZE=8192 " + q(tif)).c_str()),
            0);
  expect_clean_error(test::run_cli("info " + q(tif)), 1, "1000000 x 1000000 cells; each side may be at most 65536", "tif");
  const auto m = test::run_cli("amplify -q " + q(test::data_path("dem/N44W072.hgt")) + " -o " + q(dir.path("a.tif")) + " --dictionary " + q(crop()) +
                               " --factor 256");
  expect_clean_error(m, 1, "the x256 output of a 1201 x 1201 input", "amplify x256");
  EXPECT_FALSE(fs::exists(dir.path("a.tif")));
}

// --- 6. wrong data accepted ---------------------------------------------------------------------

TEST(Reliability, GradientExrIsNotReadAsAHeightfield) {
  test::TempDir dir;
  GradientField g(8, 6);
  write_gradient(g, dir.path("g.exr"));
  for (const std::string cmd : {"info", "metrics"}) {
    const auto r = test::run_cli(cmd + " " + q(dir.path("g.exr")));
    expect_clean_error(r, 1, "is a gradient field (2 channels", cmd);
  }
  EXPECT_THROW(read_heightfield(dir.path("g.exr")), Error);
}

TEST(Reliability, SingleCommandErodeIsByteReproducible) {
  test::TempDir dir;
  // The same command line (it is part of the provenance) run in two folders.
  for (const std::string sub : {"a", "b"}) {
    fs::create_directories(dir.path(sub));
    const std::string cmd = "cd " + q(dir.path(sub)) + " && " + TERRACL_CLI + " erode -q " + q(crop()) + " -o o.tif --steps 2";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }
  ASSERT_TRUE(fs::exists(dir.path("a/o.tif")));
  EXPECT_EQ(test::file_bytes(dir.path("a/o.tif")), test::file_bytes(dir.path("b/o.tif")));
}

TEST(Reliability, BadSidecarsAndInfiniteElevationsAreRefused) {
  test::TempDir dir;
  const Heightfield h = read_heightfield(crop());
  write_heightfield(h, dir.path("a.png"));
  json sc = json::parse(test::file_bytes(dir.path("a.png.json")));
  sc["width"] = 64;  // the sidecar of another file
  std::ofstream(dir.path("a.png.json")) << sc.dump();
  expect_clean_error(test::run_cli("info " + q(dir.path("a.png"))), 1, "sidecar says width 64, the image has 128", "size");
  sc["width"] = 128;
  sc["zmin"] = 2000;
  sc["zmax"] = 1000;
  std::ofstream(dir.path("a.png.json")) << sc.dump();
  expect_clean_error(test::run_cli("info " + q(dir.path("a.png"))), 1, "zmin <= zmax", "zmin > zmax");
  Heightfield inf = h;
  inf.z[5] = INFINITY;
  inf.z[7] = -INFINITY;
  {
    // Through OpenImageIO: terracl's own writers refuse infinite elevations.
    const std::string exr = dir.path("inf.exr");
    auto out = OIIO::ImageOutput::create(exr);
    ASSERT_TRUE(out && out->open(exr, OIIO::ImageSpec(inf.width, inf.height, 1, OIIO::TypeDesc::FLOAT)) &&
                out->write_image(OIIO::TypeDesc::FLOAT, inf.z.data()) && out->close());
  }
  expect_clean_error(test::run_cli("mesh -q " + q(dir.path("inf.exr")) + " -o " + q(dir.path("m.glb"))), 1,
                     "holds an infinite elevation", "inf");
  EXPECT_FALSE(fs::exists(dir.path("m.glb")));
}

TEST(Reliability, PreviewsAreOnlyWrittenAsPng) {
  test::TempDir dir;
  expect_clean_error(test::run_cli("render -q " + q(crop()) + " -o " + q(dir.path("x.jpg"))), 2, "use a .png name", "jpg");
  EXPECT_FALSE(fs::exists(dir.path("x.jpg")));
}

TEST(Reliability, ValidateCatchesAReconstructWithoutGradientAndToleranceIsOneKindOfError) {
  test::TempDir dir;
  std::ofstream(dir.path("r.json")) << json::array({json{{"type", "reconstruct"}}, dir.path("o.tif")}).dump();
  expect_clean_error(test::run_cli("run --validate " + q(dir.path("r.json"))), 2, "reconstruct needs a gradient", "no gradient");
  GradientField g(16, 16);
  write_gradient(g, dir.path("g.exr"));
  for (const std::string t : {"0", "nan", "-1"})
    expect_clean_error(test::run_cli("reconstruct -q --gradient " + q(dir.path("g.exr")) + " -o " + q(dir.path("o.tif")) +
                                     " --tolerance " + t),
                       2, "reconstruct/tolerance", "tolerance " + t);
}

TEST(Reliability, UnwritableCacheFolderTurnsTheCacheOffNotTheDevice) {
  test::TempDir dir;
  std::ofstream(dir.path("file")) << "x";  // a cache folder below a file cannot be created, even by root
  const std::string cmd = "env XDG_CACHE_HOME=" + q(dir.path("file/cache")) + " " + TERRACL_CLI + " erode -q " + q(crop()) +
                          " -o " + q(dir.path("e.tif")) + " --steps 1 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 0) << out;
  EXPECT_NE(out.find("is not writable; kernel caches are off"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir.path("e.tif")));
}

// Found by fuzz_raster: an EXR header attribute claiming 1.7 GB made OpenEXR allocate it (1.8 GB
// resident, 6 s) before failing on a 1.5 KB file.
TEST(Reliability, ExrHeaderClaimingHugeAttributesIsRefusedBeforeOpenExrAllocates) {
  test::TempDir dir;
  write_heightfield(read_heightfield(crop()), dir.path("a.exr"));
  std::string bytes = test::file_bytes(dir.path("a.exr"));
  const std::string key = std::string("terracl:georef") + '\0' + "string" + '\0';
  const size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  for (int i = 0; i < 4; ++i) bytes[at + key.size() + i] = char(i == 3 ? 0x65 : 0x78);  // 0x65787878 bytes
  std::ofstream(dir.path("a.exr"), std::ios::binary) << bytes;
  const auto r = test::run_cli("info " + q(dir.path("a.exr")));
  expect_clean_error(r, 1, "EXR header attribute 'terracl:georef' (string) claims 1702393976 bytes", "exr");
}

namespace {

// Sets the value of TIFF tag `tag` (SHORT or LONG, one value, little-endian classic TIFF) in `b`.
bool patch_tiff_tag(std::string& b, uint16_t tag, uint32_t value) {
  auto u16 = [&](size_t p) { return uint16_t(uint8_t(b[p]) | uint8_t(b[p + 1]) << 8); };
  auto u32 = [&](size_t p) { return uint32_t(u16(p)) | uint32_t(u16(p + 2)) << 16; };
  if (b.size() < 8 || b.compare(0, 4, std::string("II*\0", 4)) != 0) return false;
  const size_t ifd = u32(4);
  for (size_t i = 0, n = u16(ifd); i < n; ++i) {
    const size_t e = ifd + 2 + 12 * i;
    if (u16(e) != tag || u32(e + 4) != 1) continue;
    const int bytes = u16(e + 2) == 3 ? 2 : 4;
    for (int k = 0; k < bytes; ++k) b[e + 8 + k] = char((value >> (8 * k)) & 0xff);
    return true;
  }
  return false;
}

}  // namespace

// Found by fuzz_raster: a small GeoTIFF whose block table is damaged made GDAL/libtiff allocate
// what it claims (2.2 GB resident, 10 s for a 12 x 9 raster claiming 32768 x 16384 tiles) before
// failing. The blocks are checked against the raster and the file size before any pixel is read.
TEST(Reliability, TiffBlocksClaimingMoreThanTheFileAreRefusedBeforeGdalAllocates) {
  test::TempDir dir;
  const std::string good = dir.path("good.tif");
  ASSERT_EQ(std::system(("gdal_translate -q -ot Float32 -outsize 12 9 -co TILED=YES -co BLOCKXSIZE=16 -co BLOCKYSIZE=16 "
                         "-co COMPRESS=DEFLATE " + q(crop()) + " " + q(good)).c_str()),
            0);
  ASSERT_EQ(test::run_cli("info " + q(good)).exit_code, 0) << "the undamaged file reads";
  const std::string bytes = test::file_bytes(good);
  std::string tiles = bytes, count = bytes;
  ASSERT_TRUE(patch_tiff_tag(tiles, 322, 32768) && patch_tiff_tag(tiles, 323, 16384));  // TileWidth, TileLength
  ASSERT_TRUE(patch_tiff_tag(count, 325, 2000000000));                                 // TileByteCounts
  std::ofstream(dir.path("tiles.tif"), std::ios::binary) << tiles;
  std::ofstream(dir.path("count.tif"), std::ios::binary) << count;
  const auto t = test::run_cli("info " + q(dir.path("tiles.tif")));
  expect_clean_error(t, 1, "tiles.tif: the TIFF claims 32768 x 16384 cell blocks (2.0 GiB) for a 12 x 9 raster", "tile size");
  const auto c = test::run_cli("info " + q(dir.path("count.tif")));
  expect_clean_error(c, 1, "count.tif: TIFF block (0, 0) claims 2000000000 bytes at offset", "byte count");
  // The pipeline's tiled reader (GDAL windows) refuses it too.
  std::ofstream(dir.path("p.json")) << json::array({dir.path("tiles.tif"), dir.path("o.tif")}).dump();
  expect_clean_error(test::run_cli("run -q --tile 64 " + q(dir.path("p.json"))), 1, "cell blocks", "tiled reader");
  // Nothing near the claimed 2 GB was allocated (before: 2.2 GB resident).
  rusage ru{};
  ::getrusage(RUSAGE_CHILDREN, &ru);
  EXPECT_LT(ru.ru_maxrss, 1024L * 1024) << "KiB: a child's peak resident memory";
  EXPECT_FALSE(fs::exists(dir.path("o.tif")));
}

// Two findings of the 1-hour fuzz_raster campaign, kept as seeds of the fuzz corpus
// (their first byte picks the format): a 12 x 9 pixel-interleaved GeoTIFF of 65535 bands made GDAL
// calloc one 16 GiB block (17 GB resident, 127 s before failing), and an EXR whose displayWindow
// states 3 bytes made OpenEXR read on out of step into a 1.5 GB string (1.6 GB, 9 s).
TEST(Reliability, FuzzFindingsAreRefusedBeforeTheLibrariesAllocate) {
  test::TempDir dir;
  const std::string corpus = std::string(TERRACL_SOURCE_DIR) + "/tests/fuzz/corpus/raster/";
  const std::string tif = write_text(dir, "bands.tif", test::file_bytes(corpus + "seed_tif_65535_bands").substr(1));
  const std::string exr = write_text(dir, "window.exr", test::file_bytes(corpus + "seed_exr_box2i_size").substr(1));
  expect_clean_error(test::run_cli("info " + q(tif)), 1, "bands.tif: the TIFF claims 256 x 256 cell blocks (16.0 GiB)",
                     "65535 bands");
  expect_clean_error(test::run_cli("info " + q(exr)), 1,
                     "window.exr: EXR header attribute 'displayWindow' (box2i) states 3 bytes; a box2i is 16 bytes", "box2i");
  // A 1.7 KB EXR whose data window claims 11993100 x 2049 cells: OpenEXR sized its line buffers
  // from it when opening the file (30 s in the fuzz harness).
  const std::string wide = write_text(dir, "wide.exr", test::file_bytes(corpus + "seed_exr_data_window_huge").substr(1));
  expect_clean_error(test::run_cli("info " + q(wide)), 1,
                     "wide.exr: the EXR data window is 11993100 x 2049 cells; each side must be 1 to 65536 cells", "window");
  // A 12 x 9 PNG whose tEXt chunk claims more bytes than the file has: libpng allocated ~2 GB first.
  const std::string png = write_text(dir, "text.png", test::file_bytes(corpus + "seed_png_text_length").substr(1));
  expect_clean_error(test::run_cli("info " + q(png)), 1, "text.png: PNG chunk 'tEXt' claims", "the file is damaged");
  rusage ru{};
  ::getrusage(RUSAGE_CHILDREN, &ru);
  EXPECT_LT(ru.ru_maxrss, 1024L * 1024) << "KiB: a child's peak resident memory";
}

// --- 5. the subcommands and formats added since the campaign ------------------------------------

TEST(Reliability, WarpRefusesAnOutputTooLargeBeforeGdalAllocatesIt) {
  test::TempDir dir;
  const std::string base = "warp -q " + q(crop()) + " -o " + q(dir.path("w.tif"));
  // A cell size of 1e-7 (degrees: the crop is geographic) asked GDAL for 3.4 TB; 1e-12
  // and a window of 1e300 overflowed GDAL's int sizes ("-2147483648x-2147483648 dataset").
  for (const std::string& args : {base + " --tr 0.0000001 0.0000001", base + " --tr 1e-12 1e-12",
                                  base + " --projwin 0 0 1e300 -1e300"}) {
    const auto r = test::run_cli(args);
    expect_clean_error(r, 1, "warp: the output would be", args);
    EXPECT_NE(r.out.find("each side may be at most 65536 cells"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("GDAL"), std::string::npos) << r.out;
  }
  // Within the limit it still runs: the check is GDAL's own size, not a guess.
  const auto ok = test::run_cli(base + " --tr 0.00166666666666667 0.00166666666666667");
  EXPECT_EQ(ok.exit_code, 0) << ok.out;
  EXPECT_EQ(read_heightfield(dir.path("w.tif")).width, 64) << "128 cells of 3 arc-seconds at 6";
}

TEST(Reliability, NpyShapeWithASignIsRefused) {
  test::TempDir dir;
  // "(-3, 4)" was read as 3 x 4: the sign was skipped.
  std::string h = "{'descr': '<f4', 'fortran_order': False, 'shape': (-3, 4), }";
  h += std::string(118 - h.size(), ' ') + "\n";
  std::string file = std::string("\x93NUMPY\x01\x00", 8) + char(h.size() & 0xff) + char(h.size() >> 8) + h;
  file += std::string(48, '\0');
  const std::string path = write_text(dir, "neg.npy", file);
  try {
    (void)read_heightfield(path);
    FAIL() << "a negative .npy shape was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'shape' must be 2-D (rows, columns) of positive integers, got (-3, 4)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Reliability, TileFlagErrorsNameTheSubcommand) {
  test::TempDir dir;
  // parse_memory_size spoke for `terracl run` ("run: --memory-budget ...") from every subcommand.
  const auto r = test::run_cli("fill_depressions -q " + q(crop()) + " -o " + q(dir.path("f.tif")) + " --memory-budget -5G");
  expect_clean_error(r, 2, "fill_depressions: --memory-budget: '-5G' is not a memory size", "--memory-budget -5G");
  EXPECT_EQ(dir.count(), 0u);
}

// Range errors that can be known before running are refused by the option parser or --validate
// (exit 2, nothing written): `--tile 0` ran untiled without a word, `--tile 1` failed late in the
// fill, `render --scale 0` passed --validate and failed at run time with exit 1.
TEST(Reliability, TileSizeAndRenderScaleAreCheckedBeforeRunning) {
  test::TempDir dir;
  for (const char* t : {"0", "1", "-5"}) {
    const auto r = test::run_cli("fill_depressions -q " + q(crop()) + " -o " + q(dir.path("f.tif")) + " --tile " + t);
    expect_clean_error(r, 2, "--tile", std::string("--tile ") + t);
  }
  const auto r = test::run_cli("render -q " + q(crop()) + " -o " + q(dir.path("h.png")) + " --scale 0");
  expect_clean_error(r, 2, "scale", "render --scale 0");
  EXPECT_EQ(dir.count(), 0u);
}
