// libFuzzer harness: JSON text -> limited parser -> Pipeline::parse -> validate -> resolved().
// The registry holds stand-ins with every option type, unit, range and a check function, so the
// harness links only the pipeline sources (the CI budget allows no full sanitizer build).
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/pipeline.hpp>

#include <cstdint>
#include <string>

using namespace terracl;

namespace {

StageRegistry make_registry() {
  StageRegistry r;
  auto noop = [](StageContext&) {};
  r.add({"read", "reader", DataKind::None, DataKind::Heightfield,
         {{"filename", OptionType::Path, nullptr, "", "file", {}, true},
          {"zmin", OptionType::Float, nullptr, "m", "range"}},
         noop});
  r.add({"write", "writer", DataKind::Any, DataKind::None,
         {{"filename", OptionType::OutputPath, nullptr, "", "file", {}, true}}, noop});
  r.add({"erode", "erosion", DataKind::Heightfield, DataKind::Heightfield,
         {OptionSpec{"steps", OptionType::Int, 400, "", "steps"}.range(0, 1e8),
          {"time", OptionType::Float, nullptr, "s", "time"},
          OptionSpec{"rain", OptionType::Float, 1e-5, "m/s", "rain"}.range(0, {}),
          {"boundary", OptionType::Enum, "closed", "", "border", {"closed", "open"}},
          {"deposit_layer", OptionType::Bool, false, "", "layer"},
          {"region", OptionType::Path, nullptr, "", "mask"},
          {"delta", OptionType::OutputPath, nullptr, "", "delta"},
          {"extra", OptionType::Json, nullptr, "", "json"},
          {"label", OptionType::String, nullptr, "", "text"}},
         noop});
  r.add({"extract", "gradient", DataKind::Heightfield, DataKind::Gradient, {}, noop});
  r.add({"reconstruct", "poisson", DataKind::None, DataKind::Heightfield,
         {{"gradient", OptionType::Path, nullptr, "", "g"}}, noop, true,
         [](const json& o, DataKind in, const std::string& where) {
           if (in != DataKind::Gradient && o["gradient"].is_null()) fail("pipeline", "{}: needs a gradient", where);
           return DataKind::Heightfield;
         }});
  return r;
}

}  // namespace

// The library's instance() lives with the built-in stages (not linked here); stages_markdown uses it.
StageRegistry& StageRegistry::instance() {
  static StageRegistry r = make_registry();
  return r;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const StageRegistry& registry = StageRegistry::instance();
  try {
    const json doc = parse_json_limited(std::string(reinterpret_cast<const char*>(data), size), "fuzz", "input");
    Pipeline p = Pipeline::parse(doc, "fuzz", "fuzz.json", registry);
    p.validate();
    (void)p.resolved().dump();
    (void)p.hash();
  } catch (const Error&) {
    // A clear error is the expected answer to bad input; anything else escapes and is a finding.
  }
  return 0;
}
