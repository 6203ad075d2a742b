// SPDX-License-Identifier: Apache-2.0
#pragma once
// Command-line flags generated from a stage's option table, shared by every subcommand that
// runs a stage, so the CLI and pipelines accept the same names, types and units.
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

#include <CLI/CLI.hpp>

#include <map>
#include <optional>
#include <vector>
#include <string>

namespace terracl::cli {

/// "fixed_mask" -> "fixed-mask".
std::string kebab(std::string s);

/// check_output_paths over a stage's files: `inputs`/`outputs` (positional arguments, -o) plus
/// the stage's Path / OutputPath options in `resolved`, labelled by their --flag.
void check_stage_files(const StageInfo& stage, const json& resolved, std::vector<NamedPath> inputs,
                       std::vector<NamedPath> outputs);

/// --zmin/--zmax/--cell-size for the raster a command reads: the scale of a 16-bit PNG or RAW16
/// written without a sidecar (Gaea, World Machine), as convert and the pipeline read stage take it.
struct InputScaleFlags {
  std::optional<double> zmin, zmax, cell_size;
  void add(CLI::App* sub);
  ReadOptions read_options(bool fill_nodata = false) const;
};

/// --co KEY=VALUE (repeatable), --cog and --ot for commands that write a GeoTIFF heightfield.
struct OutputFlags {
  std::vector<std::string> creation_options;
  bool cog = false;
  std::string output_type = "Float32";
  std::string driver;  ///< --of
  void add(CLI::App* sub);
  WriteOptions write_options() const;
  /// write_options(), with the band type of `input` (stored_band_type) when --ot was not given and
  /// `output` is written by GDAL: as gdal_translate and gdalwarp, an Int16 DEM stays Int16.
  WriteOptions write_options_keeping_type(const std::string& input, const std::string& output) const;

 private:
  CLI::Option* m_ot = nullptr;
};

class StageFlags {
 public:
  /// Adds --kebab-name for every option of `stage` to `sub`. The option named `output_option`
  /// (if any) is also reachable as -o/--output. Options marked required stay required unless
  /// `enforce_required` is false.
  void add(CLI::App* sub, const StageInfo& stage, const std::string& output_option = "", bool enforce_required = true);
  /// The options the user gave, as JSON values of their declared types (not yet validated).
  json given(const CLI::App* sub, const StageInfo& stage) const;
  /// Options left out of add() (and given()): amplify's "tile", whose --tile is a tiled run.
  std::vector<std::string> skip;

 private:
  std::map<std::string, std::string> m_values;
  std::map<std::string, bool> m_flags;
};

}  // namespace terracl::cli
