// SPDX-License-Identifier: Apache-2.0
// `terracl bench stroke`: the latency of one landform stroke, from the operation to the re-solved
// terrain, as the studio pays it after each stroke (the session already solved, so warm-started).
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

namespace terracl {

Heightfield bench_base(const std::string& path, int n, float level) {
  Heightfield base(n, n, level);
  base.georef.cell_x = base.georef.cell_y = 10;
  if (path.empty()) return base;
  const Heightfield dem = read_heightfield(path);
  if (dem.width < n || dem.height < n)
    throw UsageError("bench", fmt::format("base '{}' is {}x{}, smaller than --size {}", path, dem.width, dem.height, n));
  const int x0 = (dem.width - n) / 2, y0 = (dem.height - n) / 2;
  base = Heightfield(n, n);
  base.georef = dem.georef;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) base.at(x, y) = dem.at(x0 + x, y0 + y);
  auto& gt = base.georef.geotransform;
  gt[0] += x0 * gt[1] + y0 * gt[2], gt[3] += x0 * gt[4] + y0 * gt[5];
  if (base.count_nodata()) fill_nodata_harmonic(base);
  return base;
}

void bench_strokes(const BenchArgs& a) {
  auto dev = Device::open(a.device);
  Device& d = *dev;
  const int n = a.size;
  const std::string base_path = a.extra.value("base", std::string());
  const Heightfield base = bench_base(base_path, n, 300.f);  // a real DEM solves locally
  // Each tool's default stroke across a third of the grid (cells); --set tool=NAME: one of them.
  const json line = {{0.3 * n, 0.55 * n}, {0.5 * n, 0.45 * n}, {0.65 * n, 0.5 * n}};
  const json centre = {0.5 * n, 0.5 * n};
  std::vector<std::pair<std::string, json>> strokes = {
      {"crest", {{"op", "crest"}, {"points", line}}},         {"mountain_range", {{"op", "mountain_range"}, {"points", line}}},
      {"river", {{"op", "river"}, {"points", line}}},         {"canyon", {{"op", "canyon"}, {"points", line}}},
      {"cliff", {{"op", "cliff"}, {"points", line}}},         {"peak", {{"op", "peak"}, {"center", centre}}},
      {"volcano", {{"op", "volcano"}, {"center", centre}}}, {"lake", {{"op", "lake"}, {"seed", centre}, {"depth", 20}}}};
  const std::string only = a.extra.value("tool", std::string());
  if (!only.empty()) {
    auto it = std::find_if(strokes.begin(), strokes.end(), [&](const auto& s) { return s.first == only; });
    if (it == strokes.end()) throw UsageError("bench", fmt::format("--set tool={}: not a landform tool of this bench", only));
    strokes = {*it};
  }
  fmt::print("stroke {}x{} on {} (median of {}), base {}: operation + warm re-solve\n", n, n, d.info().name, a.repeats,
             base_path.empty() ? "flat" : base_path);
  for (const auto& [name, op] : strokes) {
    std::vector<double> op_ms, solve_ms, total_ms;
    for (int rep = 0; rep <= a.repeats; ++rep) {  // rep 0 warms up kernel builds
      EditSession s(d, base);
      s.solve(true);
      const auto t0 = std::chrono::steady_clock::now();
      s.apply({{"units", "cells"}, {"seed", rep + 1}, {"operations", {op}}});
      const auto t1 = std::chrono::steady_clock::now();
      s.height();
      if (name == "lake") s.water();
      const auto t2 = std::chrono::steady_clock::now();
      if (rep == 0) continue;
      op_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      solve_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      total_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
    }
    auto med = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v.empty() ? 0.0 : v[v.size() / 2];
    };
    fmt::print("  {:<15} {:7.1f} ms  (operation {:6.1f} ms, solve {:6.1f} ms)\n", name, med(total_ms), med(op_ms), med(solve_ms));
  }
}

}  // namespace terracl
