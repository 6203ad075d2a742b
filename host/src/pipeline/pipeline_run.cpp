// SPDX-License-Identifier: Apache-2.0
// Running a validated pipeline: one StageData flows through the stages; every stage gets the
// provenance of the chain that produced its input, so that each output names the terracl version,
// the pipeline hash and the options of every stage behind it.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <terracl/cl.hpp>
#include <terracl/error.hpp>
#include <terracl/hypre.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/stage_memory.hpp>
#include <terracl/version.hpp>

namespace terracl {
namespace fs = std::filesystem;

// The options in the order the stage declares them, so that the file reads like docs/stages.md.
std::string Pipeline::resolved_text() const {
  const Pipeline& p = *this;
  nlohmann::ordered_json stages = nlohmann::ordered_json::array();
  for (const auto& st : p.stages()) {
    nlohmann::ordered_json o;
    o["type"] = st.type;
    o["tag"] = st.tag;
    for (const auto& spec : st.info->options) {
      const json& v = st.options.at(spec.name);
      if (!v.is_null()) o[spec.name] = v;
    }
    stages.push_back(o);
  }
  nlohmann::ordered_json doc;
  doc["terracl"] = {{"version", version()},
                    {"pipeline_hash", p.hash()},
                    {"note", "fully resolved pipeline; re-run it with `terracl run` to reproduce the outputs"}};
  doc["pipeline"] = stages;
  return doc.dump(2) + "\n";
}

namespace {

void make_parent_folder(const std::string& file) {
  const fs::path dir = fs::path(file).parent_path();
  if (dir.empty()) return;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) fail("pipeline", "cannot create the output folder {}: {}", dir.string(), ec.message());
}

}  // namespace

void Pipeline::run(const RunOptions& options, RunReport& report) const {
  if (!m_validated) throw Error("pipeline", "run() needs a validated pipeline (call validate() first)");
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  report = RunReport{};
  const std::string hash_value = hash();

  std::function<Device&()> device = options.device;
  if (!device) {
    auto opened = std::make_shared<std::shared_ptr<Device>>();
    device = [opened]() -> Device& {
      if (!*opened) *opened = Device::open();
      return **opened;
    };
  }

  // Every stage whose input size the headers tell is checked before anything is read or written.
  check_memory(device);

  StageData data;
  json chain = json::array();  // the stages behind the current data, for provenance
  // A gradient file read straight into hypre's reconstruct (and needed by no later stage) is not
  // loaded here: the reconstruct stage reads it by bands itself (docs/scale.md).
  auto hypre_reads = [&](size_t i) {
    const PipelineStage& st = m_stages[i];
    if (st.type != "read" || i + 1 >= m_stages.size() || !hypre_available()) return false;
    const PipelineStage& next = m_stages[i + 1];
    auto unset = [&](const char* k) { return !next.options.contains(k) || next.options.at(k).is_null(); };
    if (next.type != "reconstruct" || next.options.value("solver", std::string()) != "hypre" || !unset("gradient") ||
        !unset("divergence") || st.options.value("fill_nodata", false))
      return false;
    for (size_t k = i + 2; k < m_stages.size(); ++k)
      if (m_stages[k].info->input == DataKind::Gradient) return false;
    return is_gradient_file(st.options.at("filename").get<std::string>());
  };
  std::string deferred_gradient;
  json with_gradient;
  for (size_t i = 0; i < m_stages.size(); ++i) {
    const PipelineStage& st = m_stages[i];
    if (hypre_reads(i)) {
      deferred_gradient = st.options.at("filename").get<std::string>();
      report.stages.push_back(StageRun{st.type, st.tag, 0.0, st.outputs});
      json set = json::object();
      for (auto& [k, v] : st.options.items())
        if (!v.is_null()) set[k] = v;
      chain = json::array({json{{"type", st.type}, {"tag", st.tag}, {"options", set}}});
      continue;
    }
    const json* stage_options = &st.options;
    if (!deferred_gradient.empty()) {
      with_gradient = st.options;
      with_gradient["gradient"] = deferred_gradient;
      stage_options = &with_gradient;
      deferred_gradient.clear();
    }
    report.running = st.tag;
    const Progress progress = options.progress ? options.progress(st.tag, i, m_stages.size()) : Progress{};
    report_progress(progress, st.tag, 0.0, "starting");
    if (st.info->input == DataKind::None) chain = json::array();
    for (const auto& f : st.outputs) make_parent_folder(f);

    Metadata provenance{{"terracl:version", version()},
                        {"terracl:pipeline", m_name},
                        {"terracl:pipeline_hash", hash_value},
                        {"terracl:stages", chain.dump()}};
    StageContext ctx{data, *stage_options, device, progress, st.tag, provenance};
    data.current = st.input;
    const auto t0 = Clock::now();
    // Sizes only known now (after a warp by cell size, a RAW16 reader, ...): checked again before
    // the stage allocates.
    if (st.info->input != DataKind::None) {
      const RasterShape in = data.height     ? RasterShape{data.height->width, data.height->height}
                             : data.gradient ? RasterShape{data.gradient->width, data.gradient->height}
                                             : RasterShape{};
      const MemoryNeed need = memory_of(st.type, st.options, in);
      require_stage_memory(st.tag, fmt::format("pipeline stage {}", st.where), need, need.device > 0 ? &device() : nullptr);
    }
    try {
      st.info->run(ctx);
    } catch (const Cancelled&) {
      throw;
    } catch (const Error& e) {
      throw Error(e.stage(), fmt::format("{} (pipeline stage {}, tag '{}')",
                                         std::string(e.what()).substr(e.stage().size() + 2), st.where, st.tag));
    } catch (const cl::Error& e) {
      throw Error(st.tag, fmt::format("opencl: {} (pipeline stage {})", describe(e), st.where));
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();

    data.current = st.output;
    if (st.output == DataKind::Heightfield && !data.height)
      fail(st.tag, "produced no heightfield (pipeline stage {})", st.where);
    if (st.output == DataKind::Gradient && !data.gradient)
      fail(st.tag, "produced no gradient (pipeline stage {})", st.where);
    if (st.type != "write") {
      json set = json::object();
      for (auto& [k, v] : st.options.items())
        if (!v.is_null()) set[k] = v;
      chain.push_back(json{{"type", st.type}, {"tag", st.tag}, {"options", set}});
    }

    report.stages.push_back(StageRun{st.type, st.tag, seconds, st.outputs});
    report_progress(progress, st.tag, 1.0, "done");
  }
  report.running.clear();
  // Written last, so that a resolved file beside outputs always describes a complete run of them
  // (a stopped run leaves the previous one in place).
  if (options.write_resolved) {
    report.resolved_path = resolved_path();
    make_parent_folder(report.resolved_path);
    write_text_file_atomic(report.resolved_path, resolved_text());
  }
  report.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
}

}  // namespace terracl
