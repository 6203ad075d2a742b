// SPDX-License-Identifier: Apache-2.0
// The memory column against measurement: each stage's subcommand runs on a small and a large
// raster, and the growth of its peak RSS per added cell (so that the process's fixed cost, the
// OpenCL runtime and the program binaries, drops out) must stay within the estimate the
// refusal uses (terracl/stage_memory.hpp; on a CPU device its device buffers count as host
// memory). A job that passes the check therefore fits; the figures are printed for
// docs/reliability.md.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>
#include <terracl/stage_memory.hpp>

#include "test_helpers.hpp"

using namespace terracl;

namespace {

/// Peak resident memory (bytes) of `terracl ARGS`, which must succeed.
double peak_rss(const std::vector<std::string>& args) {
  const double mib = test::cli_peak_rss_mib(args);
  EXPECT_GT(mib, 0) << "terracl " << args[0] << " failed";
  return mib * 1024.0 * 1024.0;
}

// A smooth terrain with some relief everywhere (pits and ridges for the hydrology stages).
void write_terrain(int n, const std::string& path) {
  Heightfield h(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      h.at(x, y) = float(300 + 80 * std::sin(x * 0.013) * std::cos(y * 0.011) + 20 * std::sin((x + 2 * y) * 0.05));
  h.georef.cell_x = h.georef.cell_y = 30;
  write_heightfield(h, path);
}

struct Case {
  std::string stage;                                   // the memory column's stage type
  json options;                                        // its options (what memory_of reads)
  std::vector<std::string> (*args)(const std::string& size, const std::string& dir);
};

}  // namespace

TEST(StageMemory, EstimatesHoldTheMeasuredPeakPerCell) {
  test::TempDir dir;
  constexpr int kSmall = 384, kLarge = 1536;
  write_terrain(kSmall, dir.path("small.tif"));
  write_terrain(kLarge, dir.path("large.tif"));
  {
    std::ofstream(dir.path("noise.json")) << R"({"operations": [{"op": "noise", "amplitude": 5, "wavelength": 300}]})";
    std::ofstream(dir.path("crest.json"))
        << R"({"operations": [{"op": "crest", "points": [[1000, 1000], [8000, 9000]], "height": 200}]})";
  }
  const DeviceInfo& dev = test::device().info();
  const bool cpu = dev.type == "CPU";
  // Each case runs on "<dir>small.tif" and "<dir>large.tif" (t = "small" or "large").
  using Args = std::vector<std::string>;
  const std::vector<Case> cases = {
      {"write", json::object(), [](auto& t, auto& d) { return Args{"convert", d + t + ".tif", d + "w.tif"}; }},
      {"crop", json::object(), [](auto& t, auto& d) { return Args{"crop", d + t + ".tif", "--x", "1", "-o", d + "c.tif"}; }},
      {"downsample", json{{"factor", 2}},
       [](auto& t, auto& d) { return Args{"downsample", d + t + ".tif", "--factor", "2", "-o", d + "d.tif"}; }},
      {"extract", json::object(), [](auto& t, auto& d) { return Args{"extract", d + t + ".tif", "-o", d + "g_" + t + ".exr"}; }},
      {"reconstruct", json::object(), [](auto& t, auto& d) { return Args{"reconstruct", d + "g_" + t + ".exr", "-o", d + "r.tif"}; }},
      {"fill_nodata", json::object(), [](auto& t, auto& d) { return Args{"fill_nodata", d + t + ".tif", "-o", d + "n.tif"}; }},
      {"erode", json::object(), [](auto& t, auto& d) { return Args{"erode", d + t + ".tif", "--steps", "5", "-o", d + "e.tif"}; }},
      {"fill_depressions", json::object(),
       [](auto& t, auto& d) { return Args{"fill_depressions", d + t + ".tif", "-o", d + "f.tif"}; }},
      {"breach", json::object(), [](auto& t, auto& d) { return Args{"breach", d + t + ".tif", "-o", d + "b.tif"}; }},
      {"drainage", json::object(), [](auto& t, auto& d) { return Args{"drainage", d + t + ".tif", "-o", d + "a.tif"}; }},
      {"metrics", json::object(), [](auto& t, auto& d) { return Args{"metrics", d + t + ".tif", "--json", d + "m.json"}; }},
      {"sketch", json::object(), [](auto& t, auto& d) { return Args{"sketch", d + t + ".tif", "-o", d + "s.png"}; }},
      {"render", json::object(), [](auto& t, auto& d) { return Args{"render", d + t + ".tif", "-o", d + "h.png"}; }},
      {"mesh", json::object(), [](auto& t, auto& d) { return Args{"mesh", d + t + ".tif", "-o", d + "m.glb"}; }},
      {"edit", json::object(),
       [](auto& t, auto& d) { return Args{"edit", d + t + ".tif", "--script", d + "noise.json", "-o", d + "en.tif"}; }},
      {"edit", json::object(),
       [](auto& t, auto& d) { return Args{"edit", d + t + ".tif", "--script", d + "crest.json", "-o", d + "ec.tif"}; }},
  };
  const double added = double(kLarge) * kLarge - double(kSmall) * kSmall;
  for (const Case& c : cases) {
    const std::vector<std::string> small = c.args("small", dir.path(""));
    const std::vector<std::string> large = c.args("large", dir.path(""));
    const double slope = (peak_rss(large) - peak_rss(small)) / added;
    const MemoryNeed need = memory_of(c.stage, c.options, RasterShape{kLarge, kLarge});
    const double estimate = (need.host + (cpu ? need.device : 0)) / (double(kLarge) * kLarge);
    std::printf("%-17s %-12s measured %6.1f B/cell, estimate %6.1f B/cell\n", c.stage.c_str(), large[0].c_str(), slope,
                estimate);
    EXPECT_LE(slope, estimate) << c.stage << ": the estimate that refuses too-large jobs is below the measured peak";
  }
}
