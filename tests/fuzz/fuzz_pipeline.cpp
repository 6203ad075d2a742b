// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: JSON text -> limited parser -> Pipeline::parse -> validate -> resolved().
// The registry holds stand-ins with every option type, unit, range and a check function, so the
// harness links only the pipeline sources (the CI budget allows no full sanitizer build).
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

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
         {{"filename", OptionType::OutputPath, nullptr, "", "file", {}, true},
          {"creation_options", OptionType::Json, nullptr, "", "co"},
          {"cog", OptionType::Bool, false, "", "cog"}},
         noop});
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
  // The stages whose options size the data (the memory column's output_shape) and the writer's
  // GDAL creation options (--co), as the real table declares them.
  r.add({"crop", "window", DataKind::Heightfield, DataKind::Heightfield,
         {OptionSpec{"x", OptionType::Int, 0, "cells", "x"}.range(0, {}), OptionSpec{"y", OptionType::Int, 0, "cells", "y"}.range(0, {}),
          OptionSpec{"width", OptionType::Int, nullptr, "cells", "w"}.range(1, {}),
          OptionSpec{"height", OptionType::Int, nullptr, "cells", "h"}.range(1, {})},
         noop});
  r.add({"amplify", "amplify", DataKind::Heightfield, DataKind::Heightfield,
         {OptionSpec{"factor", OptionType::Int, 4, "", "factor"}.range(2, 256)}, noop});
  r.add({"downsample", "blocks", DataKind::Heightfield, DataKind::Heightfield,
         {OptionSpec{"factor", OptionType::Int, 4, "", "factor"}.range(2, {})}, noop});
  r.add({"resize", "resize", DataKind::Heightfield, DataKind::Heightfield,
         {{"preset", OptionType::String, nullptr, "", "preset"},
          OptionSpec{"width", OptionType::Int, nullptr, "cells", "w"}.range(2, 65536),
          OptionSpec{"height", OptionType::Int, nullptr, "cells", "h"}.range(2, 65536)},
         noop});
  r.add({"warp", "warp", DataKind::Heightfield, DataKind::Heightfield,
         {{"ts", OptionType::Json, nullptr, "", "size"}, {"tr", OptionType::Json, nullptr, "", "res"},
          {"t_srs", OptionType::String, nullptr, "", "crs"}},
         noop});
  r.add({"fill_depressions", "fill", DataKind::Heightfield, DataKind::Heightfield,
         {{"epsilon", OptionType::Bool, false, "", "eps"}}, noop});
  r.add({"mesh", "mesh", DataKind::Heightfield, DataKind::Heightfield,
         {{"file", OptionType::OutputPath, nullptr, "", "mesh", {}, true}, {"max_error", OptionType::Float, nullptr, "m", "err"}},
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
    // The memory column over whatever sizes the options give (no device), and the tiled run's
    // validation: each stage's tiling, and a --memory-budget text taken from the description.
    p.check_memory();
    for (const auto& st : p.stages()) (void)tiling_of(st);
    if (doc.is_object() && doc.contains("description") && doc["description"].is_string())
      (void)parse_memory_size(doc["description"].get<std::string>(), "--memory-budget");
  } catch (const Error&) {
    // A clear error is the expected answer to bad input; anything else escapes and is a finding.
  }
  return 0;
}
