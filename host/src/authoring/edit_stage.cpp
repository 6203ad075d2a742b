// SPDX-License-Identifier: Apache-2.0
// Pipeline stage `edit` (option `script`) and `terracl bench edit`.
#include "pipeline/builtin.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>

namespace terracl {
// stroke_bench.cpp: `terracl bench stroke`, and the bases of both benches (a flat n x n grid of
// 10 m cells at `level`, or the centre n x n window of the DEM at `path`).
void bench_strokes(const BenchArgs& a);
Heightfield bench_base(const std::string& path, int n, float level);

namespace {

void run_edit(StageContext& c) {
  const std::string script = c.get<std::string>("script");
  EditOptions o;
  o.progress = c.progress;
  o.base_dir = std::filesystem::path(script).parent_path().string();
  Heightfield& base = c.height();
  EditSession s(c.device(), base, o);
  s.apply(read_edit_script(script));
  Heightfield h = s.height();
  h.metadata = base.metadata;
  c.data.height = std::move(h);
  c.data.current = DataKind::Heightfield;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// 20 operations spread over an N x N grid of 10 m cells (coordinates in cells).
json bench_script(int n) {
  auto P = [n](double fx, double fy) { return json::array({fx * (n - 1), fy * (n - 1)}); };
  const double r = n * 0.04;
  json ops = json::array();
  ops.push_back({{"op", "mountain_range"}, {"points", {P(0.1, 0.2), P(0.4, 0.3), P(0.7, 0.2)}}, {"radius", 3 * r}, {"height", 800}});
  ops.push_back({{"op", "crest"}, {"points", {P(0.2, 0.5), P(0.5, 0.45)}}, {"elevation", 600}, {"radius", 2 * r}, {"height", 300}});
  ops.push_back({{"op", "crest"}, {"points", {P(0.35, 0.35), P(0.35, 0.65)}}, {"elevation", 600}, {"radius", 2 * r}, {"height", 300}});
  ops.push_back({{"op", "river"}, {"points", {P(0.05, 0.8), P(0.5, 0.75), P(0.95, 0.9)}}, {"elevation", 50}, {"radius", r}});
  ops.push_back({{"op", "river"}, {"points", {P(0.6, 0.5), P(0.55, 0.7), P(0.5, 0.75)}}, {"elevation", 60}, {"radius", r}});
  ops.push_back({{"op", "fault"}, {"points", {P(0.6, 0.05), P(0.9, 0.6)}}, {"throw", 80}, {"radius", r}});
  ops.push_back({{"op", "fault"}, {"points", {P(0.55, 0.4), P(0.95, 0.3)}}, {"throw", -50}, {"radius", r}});
  ops.push_back({{"op", "ravine"}, {"points", {P(0.7, 0.6), P(0.8, 0.8)}}, {"depth", 60}, {"radius", r}});
  ops.push_back({{"op", "ravine"}, {"points", {P(0.1, 0.6), P(0.2, 0.7)}}, {"depth", 40}, {"radius", r}});
  ops.push_back({{"op", "free_crest"}, {"points", {P(0.75, 0.7), P(0.9, 0.75)}}, {"height", 120}, {"radius", 1.5 * r}});
  ops.push_back({{"op", "free_crest"}, {"points", {P(0.15, 0.9), P(0.3, 0.95)}}, {"height", 80}, {"radius", r}});
  ops.push_back({{"op", "cliff"}, {"points", {P(0.65, 0.85), P(0.9, 0.8)}}, {"elevation", 200}, {"height", 120}, {"radius", r}});
  ops.push_back({{"op", "mesa"}, {"center", P(0.8, 0.45)}, {"radius", 0.05 * n}, {"elevation", 400}, {"height", 200}});
  ops.push_back({{"op", "scale_slopes"}, {"center", P(0.3, 0.3)}, {"radius", 2 * r}, {"falloff", r}, {"factor", 1.5}});
  ops.push_back({{"op", "scale_slopes"}, {"center", P(0.6, 0.9)}, {"radius", 2 * r}, {"falloff", r}, {"factor", 0.5}});
  ops.push_back({{"op", "noise"}, {"center", P(0.5, 0.5)}, {"radius", 5 * r}, {"falloff", 2 * r}, {"amplitude", 15}, {"wavelength", r}, {"octaves", 3}});
  ops.push_back({{"op", "noise"}, {"center", P(0.2, 0.2)}, {"radius", 2 * r}, {"falloff", r}, {"amplitude", 20}, {"wavelength", r}, {"type", "ridged"}, {"orient", {{"angle", 45}}}});
  ops.push_back({{"op", "tensor"}, {"primitives", {{{"shape", "disc"}, {"center", P(0.4, 0.25)}, {"disc_radius", r}, {"radius", 2 * r}, {"angle", 90}, {"strength", 0.7}}}}});
  ops.push_back({{"op", "tensor"}, {"primitives", {{{"shape", "polyline"}, {"points", {P(0.1, 0.4), P(0.3, 0.45)}}, {"radius", r}, {"tensor", "tangent"}}}}});
  // No freeze: it reconstructs to read the current elevations (a solve of its own).
  ops.push_back({{"op", "cliff"}, {"points", {P(0.05, 0.05), P(0.25, 0.1)}}, {"elevation", 700}, {"height", 150}, {"radius", r}});
  return {{"units", "cells"}, {"seed", 7}, {"operations", ops}};
}

void bench_edit(const BenchArgs& a) {
  auto dev = Device::open(a.device);
  Device& d = *dev;
  const int n = a.size;
  // --set base=DEM: the centre n x n window of a real DEM (local solves by default);
  // --set solve=local|global forces the mode.
  const std::string base_path = a.extra.value("base", std::string());
  const Heightfield base = bench_base(base_path, n, 100.f);
  std::optional<bool> locality;
  if (a.extra.contains("solve")) {
    const json& v = a.extra["solve"];
    if (v != "local" && v != "global") throw UsageError("bench", "--set solve= expects local or global");
    locality = v == "local";
  }
  // --set only=ops: the 20 operations alone, no solve (for counting their OpenCL calls with
  // scripts/cl-count.sh: the difference of --repeats 2 and 1 is one script).
  const bool ops_only = a.extra.value("only", std::string()) == "ops";
  if (a.extra.contains("only") && !ops_only) throw UsageError("bench", "--set only= expects ops");
  const json script = bench_script(n);
  json crest = {{"op", "crest"}, {"elevation", 500}, {"radius", n * 0.04}};
  crest["points"] = json::array({json::array({0.2 * n, 0.1 * n}), json::array({0.3 * n, 0.15 * n})});
  json one_more = {{"units", "cells"}};
  one_more["operations"] = json::array({crest});
  std::vector<double> ops_ms, solve_ms, total_ms, add_ms, warm_ms, cold_ms;
  int warm_cycles = 0, cold_cycles = 0, cycles = 0;
  json last_log, last_report;
  std::vector<double> residuals;
  double setup_ms = 0;
  for (int rep = 0; rep <= a.repeats; ++rep) {  // rep 0 warms up kernel builds
    EditOptions o;
    o.locality = locality;
    EditSession s(d, base, o);
    auto t0 = std::chrono::steady_clock::now();
    s.apply(script);
    const double t_ops = ms_since(t0);
    if (ops_only) {
      if (rep > 0) ops_ms.push_back(t_ops);
      if (rep == a.repeats) {
        fmt::print("edit {}x{} on {} (median of {}): 20 operations {:.1f} ms (no solve)\n", n, n, d.info().name,
                   a.repeats, median(ops_ms));
        return;
      }
      continue;
    }
    auto t1 = std::chrono::steady_clock::now();
    const ReconstructResult& first = s.solve(false);  // the 20-operation script solved from scratch
    cycles = first.cycles;
    residuals = first.residuals;
    setup_ms = first.setup_ms;
    const double t_solve = ms_since(t1);
    auto t2 = std::chrono::steady_clock::now();
    s.apply(one_more);
    const double t_add = ms_since(t2);
    auto t3 = std::chrono::steady_clock::now();
    warm_cycles = s.solve(true).cycles;
    const double t_warm = ms_since(t3);
    auto t4 = std::chrono::steady_clock::now();
    cold_cycles = s.solve(false).cycles;
    const double t_cold = ms_since(t4);
    if (rep == 0) continue;
    last_log = s.log();
    last_report = s.report();
    ops_ms.push_back(t_ops), solve_ms.push_back(t_solve), total_ms.push_back(t_ops + t_solve);
    add_ms.push_back(t_add), warm_ms.push_back(t_warm), cold_ms.push_back(t_cold);
  }
  fmt::print("edit {}x{} on {} (median of {}), base {}, {} solve:\n", n, n, d.info().name, a.repeats,
             base_path.empty() ? "flat" : base_path, last_report.value("solve", std::string("?")));
  if (last_report.contains("locality") && last_report["locality"].value("mode", "") == "local")
    fmt::print("  locality (last solve): {} cells changed, {} solved, falloff {:.0f} m, comparison with the base {:.1f} ms\n",
               last_report["locality"].value("changed_cells", size_t(0)), last_report["locality"].value("solved_cells", size_t(0)),
               last_report["locality"].value("falloff_m", 0.0), last_report["locality"].value("prepare_ms", 0.0));
  fmt::print("  20 operations        {:8.1f} ms\n", median(ops_ms));
  fmt::print("  reconstruction       {:8.1f} ms ({} cycles after FMG, cold; set-up {:.1f} ms in the last run)\n",
             median(solve_ms), cycles, setup_ms);
  std::string hist;
  for (double r : residuals) hist += fmt::format(" {:.1e}", r);
  fmt::print("  relative residuals  {}\n", hist);
  fmt::print("  script total         {:8.1f} ms\n", median(total_ms));
  fmt::print("  one more operation   {:8.1f} ms\n", median(add_ms));
  fmt::print("  re-solve, warm start {:8.1f} ms ({} cycles)\n", median(warm_ms), warm_cycles);
  fmt::print("  re-solve, cold       {:8.1f} ms ({} cycles)\n", median(cold_ms), cold_cycles);
  std::string per_op;
  for (const auto& e : last_log) per_op += fmt::format(" {}:{:.1f}", e["op"].get<std::string>(), e["ms"].get<double>());
  fmt::print("  per operation (ms, last run):{}\n", per_op);
}

}  // namespace

void register_edit_stages(StageRegistry& r) {
  StageInfo s{"edit",
              "Apply a JSON edit script (gradient-domain authoring, docs/authoring.md) and reconstruct the terrain.",
              DataKind::Heightfield,
              DataKind::Heightfield,
              {OptionSpec{"script", OptionType::Path, nullptr, "", "edit script (JSON)", {}, true}},
              run_edit};
  s.cli = false;  // `terracl edit` is a hand-written command (apps/cmd_edit.cpp): BASE may be flat:WxH
  r.add(std::move(s));
}

void register_edit_benches(BenchRegistry& r) {
  r.add({"edit", "20 edit operations + reconstruction, then a warm- vs cold-started re-solve after one more", bench_edit});
  r.add({"stroke", "One landform stroke of each tool (default size) + the warm re-solve, as the studio pays it; --set base=DEM, tool=NAME",
         bench_strokes});
}

}  // namespace terracl
