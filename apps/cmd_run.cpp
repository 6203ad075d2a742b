// SPDX-License-Identifier: Apache-2.0
// `terracl run pipeline.json [--validate] [--set TAG.OPTION=VALUE ...]`: runs a JSON pipeline and
// prints what it wrote with per-stage times (docs/pipelines.md).
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <terracl/distributed.hpp>
#include <terracl/error.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/stage_memory.hpp>
#include <terracl/tile.hpp>

#include "cli.hpp"
#include "tile_flags.hpp"

namespace terracl::cli {
namespace {

struct RunArgs {
  std::string file;
  bool validate = false;
  bool print_resolved = false;
  std::vector<std::string> sets;
  int tile = 0;                // --tile: run out of core, tile by tile (docs/scale.md)
  std::string halo = "auto";
  std::string memory_budget;
  bool resume = false;  // --resume: skip the tiles an interrupted run finished
};

std::string human_size(const std::string& path) {
  std::error_code ec;
  const double b = double(std::filesystem::file_size(path, ec));
  if (ec) return "?";
  if (b < 1024) return fmt::format("{:.0f} B", b);
  if (b < 1024 * 1024) return fmt::format("{:.1f} KiB", b / 1024);
  return fmt::format("{:.1f} MiB", b / (1024 * 1024));
}

bool json_progress() { return !globals().quiet && globals().progress == "json"; }

void print_validation(const Pipeline& p) {
  fmt::print("{}: valid pipeline, {} stage{}, hash {}\n", p.source(), p.stages().size(),
             p.stages().size() == 1 ? "" : "s", p.hash());
  // Columns as wide as their longest entry: "/pipeline/10" and long tags pushed the rest right.
  size_t wp = 4, wt = 3, wy = 4, wd = 4;
  for (const auto& st : p.stages()) {
    const std::string data = fmt::format("{} -> {}", data_kind_name(st.input), data_kind_name(st.output));
    wp = std::max(wp, st.where.size()), wt = std::max(wt, st.tag.size()), wy = std::max(wy, st.type.size());
    wd = std::max(wd, data.size());
  }
  fmt::print("  {:<{}} {:<{}} {:<{}} {:<{}} {}\n", "path", wp, "tag", wt, "type", wy, "data", wd, "writes");
  for (const auto& st : p.stages()) {
    const std::string data = fmt::format("{} -> {}", data_kind_name(st.input), data_kind_name(st.output));
    fmt::print("  {:<{}} {:<{}} {:<{}} {:<{}} {}\n", st.where, wp, st.tag, wt, st.type, wy, data, wd,
               fmt::join(st.outputs, " "));
  }
  fmt::print("resolved pipeline would be written to {}\n", p.resolved_path());
}

void print_report(const Pipeline& p, const RunReport& r) {
  if (json_progress()) {
    json stages = json::array();
    for (const auto& s : r.stages)
      stages.push_back({{"tag", s.tag}, {"type", s.type}, {"seconds", s.seconds}, {"outputs", s.outputs}});
    fmt::print("{}\n", json{{"event", "done"},
                            {"pipeline", p.source()},
                            {"pipeline_hash", p.hash()},
                            {"seconds", r.seconds},
                            {"stages", stages},
                            {"outputs", r.outputs()},
                            {"resolved", r.resolved_path}}
                           .dump());
    return;
  }
  fmt::print("{}: {} stage{} in {:.2f} s (pipeline hash {})\n", p.source(), r.stages.size(),
             r.stages.size() == 1 ? "" : "s", r.seconds, p.hash());
  size_t wt = 3, wy = 4;
  for (const auto& s : r.stages) wt = std::max(wt, s.tag.size()), wy = std::max(wy, s.type.size());
  fmt::print("  {:>2}  {:<{}} {:<{}} {:>9}  {}\n", "#", "tag", wt, "type", wy, "time", "wrote");
  for (size_t i = 0; i < r.stages.size(); ++i) {
    const StageRun& s = r.stages[i];
    std::string wrote;
    for (const auto& f : s.outputs) wrote += fmt::format("{}{} ({})", wrote.empty() ? "" : ", ", f, human_size(f));
    fmt::print("  {:>2}  {:<{}} {:<{}} {:>7.3f} s  {}\n", i + 1, s.tag, wt, s.type, wy, s.seconds, wrote);
  }
  if (!r.resolved_path.empty()) fmt::print("resolved pipeline: {}\n", r.resolved_path);
}

CommandRegistrar reg(40, [](CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  auto* sub = app.add_subcommand("run", "Run a JSON pipeline of stages (see docs/pipelines.md)");
  sub->add_option("pipeline", a->file, "Pipeline file: a JSON array of stages")->required()->type_name("FILE");
  sub->add_flag("--validate", a->validate,
                "Check the whole pipeline (stages, options, types, units, files, data kinds) and run nothing");
  sub->add_flag("--print-resolved", a->print_resolved, "Print the fully resolved pipeline and run nothing");
  sub->add_option("--set", a->sets,
                  "Override an option: TAG.OPTION=VALUE (repeatable; the tag defaults to the stage type)")
      ->type_name("TAG.OPTION=VALUE")
      ->allow_extra_args(false);
  sub->add_option("--tile", a->tile,
                  "Run out of core, tile by tile: tile side in cells (GDAL windows in, tiled GeoTIFF out; docs/scale.md)")
      ->check(CLI::Range(2, 1 << 30))  // 0 and 1 were silently untiled / a late 'tile size' error
      ->type_name("CELLS");
  sub->add_option("--halo", a->halo, "Halo around each tile: auto (each stage's footprint) or extra cells")
      ->type_name("auto|CELLS");
  sub->add_option("--memory-budget", a->memory_budget,
                  "Host memory for a tiled run (512M, 2G): picks --tile when not given, refuses a tile that cannot fit")
      ->type_name("BYTES");
  sub->add_flag("--resume", a->resume,
                "Tiled runs: keep a journal beside each output and, after a crash, skip the tiles already written "
                "(verified by checksum)");
  sub->callback([a] {
    Pipeline p = Pipeline::load(a->file);
    for (const auto& s : a->sets) p.set(s);
    p.validate();
    if (a->print_resolved) {
      fmt::print("{}", p.resolved_text());
      return;
    }
    if (a->validate) {
      // The run's memory check, host and device: the device's figures come from the platform list
      // (choose_device: no context, no kernels); without a device only host memory is checked. A
      // tiled run holds tiles, not whole rasters: run_tiled checks its budget itself.
      std::optional<DeviceInfo> info;
      if (a->tile == 0 && a->memory_budget.empty())
        p.check_memory_info([&info]() -> const DeviceInfo* {
          try {
            info = choose_device(globals().device);
          } catch (const Error&) {
            return nullptr;  // no OpenCL device: the run says so; validation checks what it can
          }
          return &*info;
        });
      print_validation(p);
      return;
    }
    RunOptions ro;
    ro.device = []() -> Device& { return device(); };
    const bool bar_labels = !json_progress();
    // One bar line for the whole run, relabelled per stage; the table below gives the times.
    ro.progress = [bar_labels](const std::string& tag, size_t i, size_t n) {
      return make_progress(bar_labels ? fmt::format("{}/{} {}", i + 1, n, tag) : tag);
    };
    RunReport report;
    const bool tiled = a->tile != 0 || !a->memory_budget.empty();
    TileOptions to;
    if (tiled) {
      if (a->tile < 0) throw UsageError("run", fmt::format("--tile: expected a positive number of cells, got {}", a->tile));
      to.tile = a->tile;
      if (a->halo != "auto") {
        try {
          size_t used = 0;
          to.halo = std::stoi(a->halo, &used);
          if (used != a->halo.size() || *to.halo < 0) throw std::invalid_argument(a->halo);
        } catch (const std::exception&) {
          throw UsageError("run", fmt::format("--halo: expected auto or a number of cells >= 0, got '{}'", a->halo));
        }
      }
      if (!a->memory_budget.empty()) to.memory_budget = parse_memory_size(a->memory_budget, "--memory-budget");
    } else if (a->halo != "auto") {
      throw UsageError("run", "--halo needs --tile (or --memory-budget)");
    }
    if (a->resume && !tiled)
      throw UsageError("run", "--resume needs --tile (or --memory-budget): only tiled runs keep a journal");
    to.resume = a->resume;
    TileCounts tiles;
    try {
      if (tiled) {
        keep_memory_between_tiles();
        run_tiled(p, to, ro, report, &tiles);
      } else {
        p.run(ro, report);
      }
    } catch (const Cancelled&) {
      finish_progress();
      const auto done = report.outputs();
      throw Cancelled(
          "run", fmt::format("cancelled by Ctrl-C during stage '{}'; {}; {}", report.running,
                             a->resume ? "the partial outputs and their journals stay: rerun with --resume to go on"
                                       : "no partial file was left",
                             done.empty() ? std::string("nothing was written")
                                          : fmt::format("complete outputs: {}", fmt::join(done, ", "))));
    }
    finish_progress();
    const std::string ranks = tiled ? ranks_report() : std::string();  // collective under mpirun
    if (distributed::rank() != 0) return;  // rank 0 wrote the outputs and reports them
    print_report(p, report);
    if (tiled && !json_progress())
      fmt::print("tiles: {} run{}\n", tiles.run,
                 a->resume
                     ? fmt::format(", {} finished before (verified by checksum), {} re-run after a checksum mismatch",
                                   tiles.skipped, tiles.mismatched)
                     : std::string());
    if (!ranks.empty()) {
      if (json_progress())
        fmt::print("{}\n", json{{"event", "mpi"}, {"ranks", ranks}}.dump());
      else
        fmt::print("{}\n", ranks);
    }
  });
});

}  // namespace
}  // namespace terracl::cli
