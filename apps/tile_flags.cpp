// SPDX-License-Identifier: Apache-2.0
#include "tile_flags.hpp"

#include <fmt/format.h>

#include <climits>
#include <cstdlib>

#include <terracl/distributed.hpp>
#include <terracl/error.hpp>
#include <terracl/pipeline.hpp>

#include "cli.hpp"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace terracl::cli {

void TileFlags::add(CLI::App* sub) {
  sub->add_option("--tile", tile,
                  "Run out of core, tile by tile: tile side in cells (GDAL windows in, tiled GeoTIFF out; docs/scale.md)")
      ->check(CLI::Range(2, 1 << 30))  // 0 and 1 were silently untiled / a late 'tile size' error
      ->type_name("CELLS");
  sub->add_option("--halo", halo, "Halo around each tile: auto (each stage's footprint) or extra cells")
      ->type_name("auto|CELLS");
  sub->add_option("--memory-budget", memory_budget,
                  "Host memory for a tiled run (512M, 2G): picks --tile when not given, refuses a tile that cannot fit")
      ->type_name("BYTES");
  sub->add_flag("--resume", resume,
                "Tiled runs: keep a journal beside the output and, after a crash, skip the tiles already written "
                "(verified by checksum)");
}

TileOptions TileFlags::options(const std::string& command) const {
  TileOptions to;
  if (!tiled()) {
    if (halo != "auto") throw UsageError(command, "--halo needs --tile (or --memory-budget)");
    if (resume) throw UsageError(command, "--resume needs --tile (or --memory-budget): only tiled runs keep a journal");
    return to;
  }
  to.resume = resume;
  if (tile < 0) throw UsageError(command, fmt::format("--tile: expected a positive number of cells, got {}", tile));
  to.tile = tile;
  if (halo != "auto") {
    try {
      size_t used = 0;
      to.halo = std::stoi(halo, &used);
      if (used != halo.size() || *to.halo < 0) throw std::invalid_argument(halo);
    } catch (const std::exception&) {
      throw UsageError(command, fmt::format("--halo: expected auto or a number of cells >= 0, got '{}'", halo));
    }
  }
  if (!memory_budget.empty()) {
    try {
      to.memory_budget = parse_memory_size(memory_budget, "--memory-budget");
    } catch (const UsageError& e) {
      // parse_memory_size speaks for `terracl run`; name the subcommand the user typed.
      throw UsageError(command, std::string(e.what()).substr(e.stage().size() + 2));
    }
  }
  return to;
}

// Every tile allocates and frees windows of the same tens of megabytes. main() hands more than
// 32 MB free at the heap's top back to the kernel, so each tile page-faulted its windows in again:
// a tiled 8193^2 convert (--tile 2048) took 5.2-6.1 s against 2.9 s untiled; kept: 3.4-3.5 s. The
// run's peak stays one tile's working set (docs/scale.md).
void keep_memory_between_tiles() {
#ifdef __GLIBC__
  mallopt(M_TRIM_THRESHOLD, INT_MAX);
#endif
}

void TileFlags::run_stage(const std::string& command, const std::string& input, const std::string& stage,
                          const json& stage_options, const std::string& output) const {
  const TileOptions to = options(command);
  json doc = json::array({json{{"type", "read"}, {"filename", input}}});
  if (!stage.empty()) {
    json st = json{{"type", stage}};
    for (const auto& [k, v] : stage_options.items())
      if (!v.is_null()) st[k] = v;
    doc.push_back(st);
  }
  if (!output.empty()) doc.push_back(json{{"type", "write"}, {"filename", output}});
  Pipeline p = Pipeline::parse(doc, command, "terracl " + command);
  p.validate();
  RunOptions ro;
  ro.device = []() -> Device& { return device(); };
  ro.write_resolved = false;
  ro.progress = [command](const std::string&, size_t, size_t) { return make_progress(command); };
  RunReport report;
  TileCounts tiles;
  keep_memory_between_tiles();
  try {
    run_tiled(p, to, ro, report, &tiles);
  } catch (const UsageError& e) {
    // The tile engine speaks for `terracl run` (--memory-budget, --tile, refusals): name the
    // subcommand the user typed instead.
    if (e.stage() != "run") throw;
    finish_progress();
    throw UsageError(command, std::string(e.what()).substr(e.stage().size() + 2));
  } catch (const Cancelled&) {
    finish_progress();
    throw Cancelled(command, to.resume ? "cancelled by Ctrl-C; the partial output and its journal stay: rerun with "
                                         "--resume to go on"
                                       : "cancelled by Ctrl-C; no output was written");
  }
  finish_progress();
  if (to.resume)
    fmt::print("tiles: {} run, {} finished before (verified by checksum), {} re-run after a checksum mismatch\n",
               tiles.run, tiles.skipped, tiles.mismatched);
  const std::string ranks = ranks_report();
  if (!ranks.empty() && !globals().quiet) fmt::print(stderr, "{}\n", ranks);
}

// The device this rank uses, named from the device list when the choice is an index or the default
// (opening a device only to name it cost each rank about 2 s with PoCL).
std::string rank_device_name() {
  const std::string& spec = globals().device;
  const bool env = std::getenv("OCL_DEVICE") || std::getenv("OCL_PLATFORM") || std::getenv("OCL_TYPE");
  const bool index = !spec.empty() && spec.size() < 9 && spec.find_first_not_of("0123456789") == std::string::npos;
  if (!env && (spec.empty() || index)) {
    const auto devices = list_devices();
    if (index && size_t(std::stoi(spec)) < devices.size()) return devices[size_t(std::stoi(spec))].name;
    if (spec.empty()) {
      for (const auto& d : devices)
        if (d.type == "GPU") return d.name;
      return devices.empty() ? std::string("no OpenCL device") : devices.front().name;
    }
  }
  try {
    return device().info().name;
  } catch (const std::exception& e) {
    return std::string("no OpenCL device (") + e.what() + ")";
  }
}

std::string ranks_report() {
  if (distributed::size() <= 1) return {};
  const std::string name = rank_device_name();
  const auto all = distributed::gather_text(name);
  if (distributed::rank() != 0) return {};
  std::string text = "mpi: " + distributed::describe() + ", tiles round-robin, rank 0 writes;";
  for (size_t r = 0; r < all.size(); ++r) text += fmt::format("{} rank {}: {}", r ? "," : "", r, all[r]);
  return text;
}

void TileFlags::refuse_untiled_flag(const std::string& command, bool given, const std::string& flags) {
  if (given)
    throw UsageError(command, fmt::format("{} cannot be used with --tile (tiled runs read GDAL rasters window by window "
                                          "and write a tiled float32 GeoTIFF); run untiled, or convert the tiled output",
                                          flags));
}

}  // namespace terracl::cli
