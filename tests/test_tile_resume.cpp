// SPDX-License-Identifier: Apache-2.0
// `--resume` of tiled runs (docs/scale.md): a run killed after N tiles (SIGKILL from the test-only
// hook TERRACL_TEST_KILL_AFTER_TILES, so nothing is cleaned up) leaves its partial outputs and
// journals; the rerun skips the N tiles after verifying their checksums, runs only the rest and
// writes the same file, byte for byte, as an uninterrupted run.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"

namespace terracl {
namespace {
namespace fs = std::filesystem;

using test::bit_differences;

// An odd-sized SRTM window with nodata holes across tile borders, and a pipeline with writers at
// two levels (after a crop, and after a second crop).
struct Job {
  test::TempDir dir;
  std::string pipeline, a, b;
  Job() {
    const Heightfield dem = read_heightfield(test::data_path("dem/N44W072.hgt"));
    Heightfield t(203, 151);
    t.georef = dem.georef;
    for (int y = 0; y < t.height; ++y)
      for (int x = 0; x < t.width; ++x) {
        const bool hole = (x - 60) * (x - 60) + (y - 70) * (y - 70) < 81 || (x * 7 + y * 13) % 97 == 0;
        t.at(x, y) = hole ? NAN : dem.at(x + 300, y + 400);
      }
    const std::string in = dir.path("in.tif");
    write_heightfield(t, in);
    a = dir.path("a.tif");
    b = dir.path("b.tif");
    pipeline = dir.path("p.json");
    std::ofstream(pipeline) << R"([")" << in << R"(", {"type": "crop", "x": 3, "y": 2}, ")" << a
                            << R"(", {"type": "crop", "x": 17, "y": 5, "width": 151, "height": 117}, ")" << b
                            << R"("])";
  }
  test::CmdResult run(const std::string& flags, int kill_after = 0) const {
    if (kill_after) setenv("TERRACL_TEST_KILL_AFTER_TILES", std::to_string(kill_after).c_str(), 1);
    auto r = test::run_cli("run " + pipeline + " " + flags);
    unsetenv("TERRACL_TEST_KILL_AFTER_TILES");
    return r;
  }
  size_t journal_tiles(const std::string& out) const {
    std::istringstream in(test::file_bytes(out + ".journal"));
    std::string line;
    size_t n = 0;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) n += !line.empty();
    return n;
  }
};

// 203 x 151, tiles of 32 at the source: 7 x 5 = 35 tiles (the crop's grid shifts them).
const char* kTiled = "--tile 32 --resume";

TEST(TileResume, KilledRunResumesToTheSameFileRunningOnlyTheRest) {
  Job job;
  // The uninterrupted run, moved aside (same pipeline file, so the same provenance in the file).
  auto full = job.run(kTiled);
  ASSERT_EQ(full.exit_code, 0) << full.out;
  EXPECT_NE(full.out.find("tiles: 35 run, 0 finished before"), std::string::npos) << full.out;
  EXPECT_FALSE(fs::exists(job.a + ".journal"));  // removed with the finished output
  const std::string full_a = test::file_bytes(job.a), full_b = test::file_bytes(job.b);
  fs::remove(job.a);
  fs::remove(job.b);

  // Killed after 12 tiles: no output under its name, the partial files and journals stay.
  auto killed = job.run(kTiled, 12);
  EXPECT_NE(killed.exit_code, 0) << killed.out;
  EXPECT_FALSE(fs::exists(job.a));
  EXPECT_FALSE(fs::exists(job.b));
  EXPECT_TRUE(fs::exists(job.dir.path(".a.partial.tif")));
  EXPECT_EQ(job.journal_tiles(job.a), 12u);
  EXPECT_EQ(job.journal_tiles(job.b), 11u);  // the 7th tile of the first row lies right of b's crop

  // Resumed, and killed again after 10 more tiles: 22 finished.
  auto again = job.run(kTiled, 10);
  EXPECT_NE(again.exit_code, 0) << again.out;
  EXPECT_EQ(job.journal_tiles(job.a), 22u);

  auto resumed = job.run(kTiled);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("tiles: 13 run, 22 finished before (verified by checksum), 0 re-run"), std::string::npos)
      << resumed.out;
  EXPECT_TRUE(test::file_bytes(job.a) == full_a) << "a.tif differs from the uninterrupted run's bytes";
  EXPECT_TRUE(test::file_bytes(job.b) == full_b) << "b.tif differs from the uninterrupted run's bytes";
  EXPECT_FALSE(fs::exists(job.a + ".journal"));
  EXPECT_FALSE(fs::exists(job.dir.path(".a.partial.tif")));

  // The same cells as a run without --resume (whose file is laid out without per-tile flushes).
  fs::rename(job.a, job.dir.path("resumed_a.tif"));
  ASSERT_EQ(job.run("--tile 32").exit_code, 0);
  EXPECT_EQ(bit_differences(read_heightfield(job.a), read_heightfield(job.dir.path("resumed_a.tif"))), 0u);
}

TEST(TileResume, ChecksumMismatchReRunsTheTileAndAnotherRunStartsAfresh) {
  Job job;
  ASSERT_EQ(job.run(kTiled).exit_code, 0);
  const std::string full_a = test::file_bytes(job.a);
  fs::remove(job.a);
  fs::remove(job.b);

  ASSERT_NE(job.run(kTiled, 9).exit_code, 0);
  // Damage one journaled checksum of a.tif's journal: that tile must run again.
  std::string j = test::file_bytes(job.a + ".journal");
  const size_t line = j.find('\n', j.find('\n') + 1) + 1;  // the second tile's line
  const size_t sum = j.find(' ', line) + 1;
  j[sum] = j[sum] == '0' ? '1' : '0';
  std::ofstream(job.a + ".journal", std::ios::binary) << j;
  auto resumed = job.run(kTiled);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("tiles: 27 run, 8 finished before (verified by checksum), 1 re-run after a checksum "
                             "mismatch"),
            std::string::npos)
      << resumed.out;
  EXPECT_TRUE(test::file_bytes(job.a) == full_a);

  // A journal of another run (another tile size) is not trusted: everything runs.
  fs::remove(job.a);
  fs::remove(job.b);
  ASSERT_NE(job.run(kTiled, 5).exit_code, 0);
  auto other = job.run("--tile 50 --resume");
  ASSERT_EQ(other.exit_code, 0) << other.out;
  EXPECT_NE(other.out.find("tiles: 20 run, 0 finished before"), std::string::npos) << other.out;
}

// A stop request (Ctrl-C: the CLI's stop check) is honoured inside a tile - between its stages and
// between its outputs' windows - and the stopped tile is not journaled: at every stop point of a
// tile, the resumed run reports no mismatch and writes the uninterrupted run's bytes.
TEST(TileResume, StopInsideATileJournalsOnlyWholeTiles) {
  Job job;
  ASSERT_EQ(job.run(kTiled).exit_code, 0);
  const std::string full_a = test::file_bytes(job.a), full_b = test::file_bytes(job.b);
  auto run = [&](TileCounts* counts) {
    Pipeline p = Pipeline::parse(json::parse(test::file_bytes(job.pipeline)), "p", job.pipeline);
    p.validate();
    RunOptions ro;
    ro.device = []() -> Device& { return test::device(); };
    ro.write_resolved = false;
    RunReport r;
    TileOptions to;
    to.tile = 32;
    to.resume = true;
    run_tiled(p, to, ro, r, counts);
  };
  // A tile makes about 7 stop checks (4 stages, 2 outputs, the journal): 8 consecutive stop points
  // cover each place inside one.
  for (int stop_at = 60; stop_at < 68; ++stop_at) {
    SCOPED_TRACE(stop_at);
    fs::remove(job.a);
    fs::remove(job.b);
    int calls = 0;
    set_stop_check([&] { return ++calls >= stop_at; });
    bool cancelled = false;
    try {
      run(nullptr);
    } catch (const Cancelled&) {
      cancelled = true;
    }
    set_stop_check({});
    EXPECT_TRUE(cancelled) << "the stop request was not honoured (" << calls << " checks)";
    EXPECT_EQ(calls, stop_at);
    EXPECT_FALSE(fs::exists(job.a));
    const size_t journaled = job.journal_tiles(job.a);
    EXPECT_GT(journaled, 5u);
    EXPECT_LT(journaled, 12u);
    TileCounts counts;
    run(&counts);
    EXPECT_EQ(counts.mismatched, 0u);
    EXPECT_EQ(counts.skipped, journaled);
    EXPECT_EQ(counts.run + counts.skipped, 35u);
    EXPECT_TRUE(test::file_bytes(job.a) == full_a);
    EXPECT_TRUE(test::file_bytes(job.b) == full_b);
  }
}

TEST(TileResume, UsageErrors) {
  Job job;
  auto untiled = job.run("--resume");
  EXPECT_EQ(untiled.exit_code, 2) << untiled.out;
  EXPECT_NE(untiled.out.find("--resume needs --tile"), std::string::npos) << untiled.out;
  const std::string hs = job.dir.path("hs.tif");
  auto render = test::run_cli("render " + job.dir.path("in.tif") + " -o " + hs + " --tile 64 --resume");
  EXPECT_EQ(render.exit_code, 2) << render.out;
  EXPECT_NE(render.out.find("cannot --resume"), std::string::npos) << render.out;
  auto sub = test::run_cli("convert " + job.dir.path("in.tif") + " " + job.dir.path("d.tif") + " --tile 40 --resume");
  ASSERT_EQ(sub.exit_code, 0) << sub.out;
  EXPECT_NE(sub.out.find("tiles: 24 run, 0 finished before"), std::string::npos) << sub.out;
  // A second resumable run of an output that a run is writing (its journal locked) is refused.
  const std::string e = job.dir.path("e.tif");
  const int fd = ::open((e + ".journal").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  auto locked = test::run_cli("convert " + job.dir.path("in.tif") + " " + e + " --tile 40 --resume");
  ::close(fd);
  EXPECT_NE(locked.exit_code, 0) << locked.out;
  EXPECT_NE(locked.out.find("is locked: another run is writing this output"), std::string::npos) << locked.out;
  EXPECT_FALSE(fs::exists(e));
}

}  // namespace
}  // namespace terracl
