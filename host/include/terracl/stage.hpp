// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Self-describing stages (PDAL's convention). Each stage declares once its name, a one-line
/// description and its options; that table drives `terracl <stage> --help`, `terracl stages`,
/// pipeline validation and docs/stages.md.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace terracl {

/// Stage options are JSON values (pipelines are JSON; the CLI converts flags to JSON).
using json = nlohmann::json;

/// Type of a stage option; Path options must exist, OutputPath options are written by the stage.
enum class OptionType { String, Int, Float, Bool, Path, OutputPath, Enum, Json };
const char* option_type_name(OptionType t);

/// One declared stage option: it drives --help, pipeline validation and docs/stages.md.
struct OptionSpec {
  std::string name;            ///< snake_case in JSON; the CLI flag is --kebab-case
  OptionType type = OptionType::String;
  json default_value;          ///< null: no default (optional unless `required`)
  std::string unit;            ///< "m", "m/s", "deg", "cells", ... ("" when unitless)
  std::string help;
  std::vector<std::string> choices = {};  ///< for Enum
  bool required = false;
  /// Smallest / largest value accepted (Int and Float, in `unit`); checked by resolve_options, so
  /// `--validate` and every subcommand refuse it before any work. Ints are always within int32.
  std::optional<double> min = std::nullopt, max = std::nullopt;
  /// A copy with the range [lo, hi] (either may be nullopt).
  OptionSpec range(std::optional<double> lo, std::optional<double> hi) const {
    OptionSpec c = *this;
    c.min = lo;
    c.max = hi;
    return c;
  }
};

/// What a stage consumes from the previous one and produces for the next.
/// As an input, None means the stage starts a new chain (a reader or a generator) and Any means a
/// heightfield or a gradient (a writer). As an output, None and Any both mean the stage passes its
/// input on unchanged (it may still write files of its own through OutputPath options).
enum class DataKind { None, Heightfield, Gradient, Any };
/// "heightfield", "gradient", "nothing", "heightfield or gradient".
const char* data_kind_name(DataKind k);

/// The values flowing through a pipeline.
struct StageData {
  std::optional<Heightfield> height;
  std::optional<GradientField> gradient;
  DataKind current = DataKind::None;  ///< what the last stage produced
};

/// What a stage's run function receives.
struct StageContext {
  StageData& data;
  const json& options;         ///< validated, defaults filled in, units converted to the spec's unit
  std::function<Device&()> device;  ///< opens the device on first use
  Progress progress;
  std::string tag;
  Metadata provenance;         ///< copied into every output written by the stage

  bool has(const std::string& name) const { return options.contains(name) && !options.at(name).is_null(); }
  template <typename T>
  T get(const std::string& name) const { return options.at(name).get<T>(); }
  /// The heightfield input; throws a clear error when the previous stage produced none.
  Heightfield& height();
  GradientField& gradient();
};

/// A self-describing stage (PDAL's convention): name, summary, data kinds, options, run.
struct StageInfo {
  std::string name;
  std::string description;
  DataKind input = DataKind::Heightfield;
  DataKind output = DataKind::Heightfield;
  std::vector<OptionSpec> options;
  std::function<void(StageContext&)> run;
  /// When false the stage is a pipeline-only stage with no auto-generated CLI subcommand.
  bool cli = true;
  /// Optional extra validation at `--validate` time, after the options are resolved: receives the
  /// resolved options, the kind the previous stage produces and the stage's JSON path; throws a
  /// clear error (naming `where`) or returns the kind the stage will produce (for stages whose
  /// output depends on their options, e.g. a reader of a gradient .exr).
  std::function<DataKind(const json& options, DataKind input, const std::string& where)> check = nullptr;
};

/// Every stage the CLI and pipelines know, by name.
class StageRegistry {
 public:
  static StageRegistry& instance();  ///< with all built-in stages registered
  void add(StageInfo info);
  const StageInfo* find(const std::string& name) const;
  const std::vector<StageInfo>& all() const { return m_stages; }

 private:
  std::vector<StageInfo> m_stages;
};

/// Validates `options` of `stage` (unknown names, types, enum choices, units, required options,
/// input files existing) and returns them with defaults filled in. Error messages name `where`
/// (a JSON path such as "/2/steps"). Input files listed in `pending_outputs` (written by an
/// earlier stage of the same pipeline) need not exist yet.
json resolve_options(const StageInfo& stage, const json& options, const std::string& where,
                     const std::vector<std::string>& pending_outputs = {});

/// Command-line text ("12", "2 km", "true", "[1,2]") to a JSON value for option `o`; values that do
/// not parse as the option's type stay strings so that resolve_options reports them clearly.
json option_from_text(const OptionSpec& o, const std::string& text);

/// Converts a value with a unit ("5 km", "30 deg", 12) to `unit`; throws naming `where`.
double convert_unit(const json& value, const std::string& unit, const std::string& where);

/// Markdown table of every stage and option (docs/stages.md). Stages without a generated
/// subcommand are marked "pipeline only" unless named in `commands` (the CLI's hand-written
/// subcommands: render, warp, ...).
std::string stages_markdown(const std::vector<std::string>& commands = {});

/// `terracl render IN -o FILE` without IN in memory: when render::can_stream_render allows it, renders
/// the picture strip by strip with `c`'s render options (c.data is not used) and returns true;
/// otherwise returns false and the caller reads IN and runs the stage.
bool run_render_streamed(const std::string& input, StageContext& c);
/// Whether run_render_streamed would stream this render (it holds a few strips, never the raster).
bool render_streams(const std::string& input, const StageContext& c);

/// Benchmarks for `terracl bench <name>`: print their figures on stdout.
struct BenchArgs {
  int size = 1025;
  int repeats = 10;
  std::string device;
  json extra;  ///< benchmark-specific options
};
/// One `terracl bench` benchmark.
struct BenchInfo {
  std::string name;
  std::string description;
  std::function<void(const BenchArgs&)> run;
};
/// Every benchmark, by name.
class BenchRegistry {
 public:
  static BenchRegistry& instance();
  void add(BenchInfo info) { m_benches.push_back(std::move(info)); }
  const BenchInfo* find(const std::string& name) const;
  const std::vector<BenchInfo>& all() const { return m_benches; }

 private:
  std::vector<BenchInfo> m_benches;
};

}  // namespace terracl
