// SPDX-License-Identifier: Apache-2.0
#pragma once
// Helpers shared by the tests: the default device (a hard failure under CI when none exists),
// temporary folders, and running the built CLI as a user would.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace terracl::test {

/// The default device; the test fails (never skips) when there is none.
Device& device();

/// A fresh, empty folder under the system temp dir, removed at exit of the test.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  std::string path(const std::string& name) const { return (m_dir / name).string(); }
  const std::filesystem::path& dir() const { return m_dir; }
  /// Number of entries in the folder (to check that nothing partial was left behind).
  size_t count() const;

 private:
  std::filesystem::path m_dir;
};

struct CmdResult {
  int exit_code;
  std::string out;  ///< stdout and stderr together
};
/// Runs the built `terracl` with `args` (a shell-quoted string).
CmdResult run_cli(const std::string& args);
/// Peak resident memory (MiB) of the built `terracl` run with `args` (no shell in between), or -1
/// when it failed. Measured from a small parent process (tests/tools/peak_rss.cpp): a child forked
/// from the test binary would report at least the test binary's own resident size.
double cli_peak_rss_mib(const std::vector<std::string>& args);

/// The whole content of a file (empty when it cannot be read).
std::string file_bytes(const std::string& path);

/// Path of a file under the repository's data/ folder.
std::string data_path(const std::string& rel);

/// The n x n window of data/dem/N44W072.hgt at cell (x0, y0), nodata filled, with the tile's georef
/// (its cell size): a real DEM for tests of operations on real terrain.
Heightfield n44_window(int x0, int y0, int n);

/// A smooth synthetic terrain (sum of sines) with the given cell size, for numerics tests.
Heightfield smooth_terrain(int w, int h, double cell = 10.0, double relief = 500.0, unsigned seed = 1);

/// Cells whose float32 bits differ (any NaN equals any NaN: nodata); size_t(-1) when the sizes differ.
size_t bit_differences(const Heightfield& a, const Heightfield& b);

/// D8 drainage area of every cell in units of `cell_area` per cell: each cell passes its area to
/// its steepest lower neighbour of 8 (metric distances), highest cell first; pits keep theirs.
/// (The reference of the erosion tests and of scripts/erosion-look.py's valley-ribbon figure.)
std::vector<double> d8_area(const Heightfield& h, double cell_area = 1.0);

}  // namespace terracl::test
