// Pipeline::check_memory: the memory column (terracl/stage_memory.hpp) applied to every stage
// before any work, sizes flowing from the readers' headers; the same pass serves `--validate`.
#include <fmt/format.h>

#include <map>
#include <terracl/error.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/stage_memory.hpp>

namespace terracl {

void Pipeline::check_memory(const std::function<Device&()>& device) const {
  if (!m_validated) throw Error("pipeline", "check_memory() needs a validated pipeline (call validate() first)");
  std::map<std::string, RasterShape> written;  // files written earlier in this pipeline
  RasterShape current;
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
    const Device* d = nullptr;
    if (device && need.device > 0) d = &device();
    try {
      require_stage_memory("pipeline", st.where, need, d);
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
