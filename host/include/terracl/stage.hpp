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

using json = nlohmann::json;

enum class OptionType { String, Int, Float, Bool, Path, OutputPath, Enum, Json };
const char* option_type_name(OptionType t);

struct OptionSpec {
  std::string name;            ///< snake_case in JSON; the CLI flag is --kebab-case
  OptionType type = OptionType::String;
  json default_value;          ///< null: no default (optional unless `required`)
  std::string unit;            ///< "m", "m/s", "deg", "cells", ... ("" when unitless)
  std::string help;
  std::vector<std::string> choices;  ///< for Enum
  bool required = false;
};

/// What a stage consumes from the previous one and produces for the next.
enum class DataKind { None, Heightfield, Gradient };

/// The values flowing through a pipeline.
struct StageData {
  std::optional<Heightfield> height;
  std::optional<GradientField> gradient;
  DataKind current = DataKind::None;  ///< what the last stage produced
};

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

struct StageInfo {
  std::string name;
  std::string description;
  DataKind input = DataKind::Heightfield;
  DataKind output = DataKind::Heightfield;
  std::vector<OptionSpec> options;
  std::function<void(StageContext&)> run;
  /// When false the stage is a pipeline-only stage with no auto-generated CLI subcommand.
  bool cli = true;
};

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
/// (a JSON path such as "/2/steps").
json resolve_options(const StageInfo& stage, const json& options, const std::string& where);

/// Converts a value with a unit ("5 km", "30 deg", 12) to `unit`; throws naming `where`.
double convert_unit(const json& value, const std::string& unit, const std::string& where);

/// Markdown table of every stage and option (docs/stages.md).
std::string stages_markdown();

/// Benchmarks for `terracl bench <name>`: print their figures on stdout.
struct BenchArgs {
  int size = 1025;
  int repeats = 10;
  std::string device;
  json extra;  ///< benchmark-specific options
};
struct BenchInfo {
  std::string name;
  std::string description;
  std::function<void(const BenchArgs&)> run;
};
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
