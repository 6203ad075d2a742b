// SPDX-License-Identifier: Apache-2.0
#pragma once
// --tile / --halo / --memory-budget: out-of-core runs (docs/scale.md), for `terracl run` and the
// subcommands of stages that tile. A subcommand builds the one-stage pipeline read -> stage ->
// write and hands it to the same tile runner as `terracl run --tile`.
#include <CLI/CLI.hpp>
#include <string>
#include <terracl/stage.hpp>
#include <terracl/tile.hpp>

namespace terracl::cli {

struct TileFlags {
  int tile = 0;
  std::string halo = "auto";
  std::string memory_budget;
  bool resume = false;
  void add(CLI::App* sub);
  /// --tile or --memory-budget given.
  bool tiled() const { return tile != 0 || !memory_budget.empty(); }
  /// The options, or a UsageError naming `command` and the flag.
  TileOptions options(const std::string& command) const;
  /// Runs the pipeline read(input) -> stage (type `stage`, `options` resolved; none when empty) ->
  /// write(output, when not empty) tiled, with the command's progress bar.
  void run_stage(const std::string& command, const std::string& input, const std::string& stage,
                 const json& stage_options, const std::string& output) const;
  /// Refuses reader/writer flags that a tiled run (GDAL windows in, tiled float32 GeoTIFF out) cannot honour.
  static void refuse_untiled_flag(const std::string& command, bool given, const std::string& flags);
};

/// Under mpirun with several ranks: at rank 0, "mpi: <library>, N ranks; rank 0: <device>, rank 1:
/// ..." (the OpenCL device each rank uses); "" elsewhere or in one process. Collective: every rank
/// of a tiled run calls it once the run is done.
std::string ranks_report();

/// Before a tiled run: freed memory stays in the heap for the next tile (see tile_flags.cpp).
void keep_memory_between_tiles();

}  // namespace terracl::cli
