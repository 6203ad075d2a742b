// SPDX-License-Identifier: Apache-2.0
// Pipeline::check_memory: the memory column (terracl/stage_memory.hpp) applied to every stage
// before any work, sizes flowing from the readers' headers; the same pass serves `--validate`.
#include <fmt/format.h>

#include <map>
#include <terracl/error.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/stage_memory.hpp>

namespace terracl {

void Pipeline::check_memory(const std::function<Device&()>& device) const {
  if (!device) return check_memory_info({});
  check_memory_info([&device]() -> const DeviceInfo* { return &device().info(); });
}

void Pipeline::check_memory_info(const std::function<const DeviceInfo*()>& device_info) const {
  if (!m_validated) throw Error("pipeline", "check_memory() needs a validated pipeline (call validate() first)");
  std::map<std::string, RasterShape> written;  // files written earlier in this pipeline
  RasterShape current;
  bool asked = false;  // device_info is called once: it may open the platform list or a device
  const DeviceInfo* d = nullptr;
  for (const PipelineStage& st : m_stages) {
    RasterShape in = current;
    if (st.info->input == DataKind::None) {
      in = {};
      if (st.options.contains("filename") && st.options.at("filename").is_string()) {
        const std::string f = st.options.at("filename").get<std::string>();
        auto it = written.find(f);
        in = it != written.end() ? it->second : raster_shape(f);
      }
    }
    const MemoryNeed need = memory_of(st.type, st.options, in);
    if (device_info && need.device > 0 && !asked) d = device_info(), asked = true;
    try {
      require_stage_memory_info("pipeline", st.where, need, need.device > 0 ? d : nullptr);
    } catch (const UsageError&) {
      throw;
    } catch (const Error& e) {
      error(std::string(e.what()).substr(e.stage().size() + 2));
    }
    current = st.info->input == DataKind::None ? in : need.output;
    for (const auto& f : st.outputs) written[f] = current;
  }
}

}  // namespace terracl
