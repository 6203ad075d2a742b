// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Pipelines (PDAL's convention): an ordered JSON array of stages, each
/// `{"type": "<stage>", "tag": "...", <options>...}`, run one after the other on the values that flow
/// between them (see docs/pipelines.md). Shorthands: a bare file name is a reader when it is the
/// first element and a writer anywhere else; a bare stage name is that stage with default options;
/// an object with a "filename" and no "type" is a reader (first) or a writer (elsewhere).
///
/// Life of a pipeline: `Pipeline::load` (or `parse`) expands the shorthands and gives every stage a
/// tag; `set("TAG.OPTION=VALUE")` overrides options; `validate()` resolves every option (defaults,
/// types, units, files) and checks that the data kinds chain; `run()` executes it. Errors name the
/// pipeline file and the JSON path of the offending value ("demo.json: /2/steps: ...").
#include <functional>
#include <string>
#include <terracl/stage.hpp>
#include <vector>

namespace terracl {

/// One stage of a parsed pipeline.
struct PipelineStage {
  std::string type;
  std::string tag;    ///< unique; defaults to the type, or type + occurrence (write1, write2) when repeated
  std::string where;  ///< JSON path of the stage in the pipeline file ("/2")
  json options;       ///< as written (plus overrides); fully resolved after validate()
  const StageInfo* info = nullptr;
  DataKind input = DataKind::None;   ///< after validate(): the kind this stage receives
  DataKind output = DataKind::None;  ///< after validate(): the kind it hands to the next stage
  std::vector<std::string> outputs;  ///< after validate(): files this stage writes
};

/// One stage's record from a run.
struct StageRun {
  std::string type, tag;
  double seconds = 0;
  std::vector<std::string> outputs;  ///< files completed by this stage
};

/// What a run did, also when it stopped early.
struct RunReport {
  std::vector<StageRun> stages;  ///< stages completed so far (filled while running)
  std::string running;           ///< tag of the stage running when an error or Ctrl-C stopped the run
  std::string resolved_path;     ///< where the resolved pipeline was written ("" if not written)
  double seconds = 0;
  std::vector<std::string> outputs() const;
};

/// How a pipeline runs: its device, progress reporting and the resolved file.
struct RunOptions {
  /// Opens the device on first use (stages that need none never open it).
  std::function<Device&()> device;
  /// Progress callback for stage `index` (0-based) of `count`, tagged `tag`; may return {} for none.
  /// The runner also reports 0 and 1 around each stage, so a callback that returns false (Ctrl-C)
  /// stops the run between stages with Cancelled.
  std::function<Progress(const std::string& tag, size_t index, size_t count)> progress;
  /// Write `<first output folder>/<name>.resolved.json` when the run completes.
  bool write_resolved = true;
};

/// A JSON pipeline (docs/pipelines.md): parse or load, optionally set overrides, validate, run.
class Pipeline {
 public:
  /// Parses a pipeline document: a JSON array of stages, or an object with a "pipeline" array (and
  /// optionally a "description" text and "terracl" run information, both ignored).
  /// `name` names the resolved file; `source` prefixes error messages (usually the file name).
  static Pipeline parse(const json& doc, const std::string& name, const std::string& source,
                        const StageRegistry& registry = StageRegistry::instance());
  /// Reads and parses a pipeline file; the name is the file's stem without ".resolved".
  static Pipeline load(const std::string& path, const StageRegistry& registry = StageRegistry::instance());

  /// Applies an override "TAG.OPTION=VALUE" (VALUE as on the command line: "2 km", "true", "[1,2]").
  void set(const std::string& assignment);
  /// Resolves every option and checks the chain of data kinds; throws UsageError naming the path.
  void validate();

  /// The fully resolved pipeline (explicit stages, every option with its value; valid input to
  /// parse, and parsing it gives the same resolved pipeline). Requires validate().
  json resolved() const;
  /// The resolved pipeline file's text: {"terracl": {version, pipeline_hash}, "pipeline": [...]},
  /// each stage's type and tag first, then its options in the order the stage declares them.
  std::string resolved_text() const;
  /// FNV-1a 64-bit hash (16 hex digits) of resolved().dump(): the provenance key of a run.
  std::string hash() const;
  /// Every file the pipeline writes, in order.
  std::vector<std::string> outputs() const;
  /// `<folder of the first output>/<name>.resolved.json`.
  std::string resolved_path() const;

  /// Runs a validated pipeline. `report` is filled as stages complete, so that it still tells what
  /// was done when the run throws (a stage error, or Cancelled after Ctrl-C). Outputs are written
  /// atomically: a stopped run leaves complete files only. Stage errors are rethrown with the tag
  /// and JSON path of the stage appended.
  void run(const RunOptions& options, RunReport& report) const;

  /// The stage table's memory column over the whole pipeline (terracl/stage_memory.hpp): sizes
  /// from the readers' headers (no pixels read) through every stage; throws UsageError naming the
  /// stage's JSON path, how much it needs and what to change when one cannot fit the host memory
  /// (or, given `device`, which is then opened if a stage of known size uses it, the device's).
  /// `terracl run`, `run --validate` and run() call it before any work. Requires validate().
  void check_memory(const std::function<Device&()>& device = {}) const;
  /// The same check with the device's figures alone (choose_device(): the platform list, no
  /// context or kernels), for `run --validate`. `device_info` is called once, when the first stage
  /// of known size uses device memory; it may return nullptr (no device: host memory only).
  void check_memory_info(const std::function<const DeviceInfo*()>& device_info) const;

  const std::string& name() const { return m_name; }
  const std::string& source() const { return m_source; }
  const std::vector<PipelineStage>& stages() const { return m_stages; }

 private:
  [[noreturn]] void error(const std::string& message) const;
  std::string m_name, m_source;
  std::vector<PipelineStage> m_stages;
  bool m_validated = false;
};

}  // namespace terracl
