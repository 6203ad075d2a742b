// Shared by the tiled-pipeline tests: one pipeline run untiled and tiled, side by side.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"

namespace terracl::test {

/// Runs `doc` (with OUT in file names replaced by the folder) untiled into dir/u and tiled into dir/t.
inline void run_untiled_and_tiled(const TempDir& dir, const std::string& doc, const TileOptions& to) {
  for (const char* which : {"u", "t"}) {
    std::string text = doc;
    const std::string out = dir.path(which);
    for (size_t p; (p = text.find("OUT")) != std::string::npos;) text.replace(p, 3, out);
    Pipeline p = Pipeline::parse(nlohmann::json::parse(text), "tiles", "tiles.json");
    p.validate();
    RunOptions ro;
    ro.device = []() -> Device& { return device(); };
    ro.write_resolved = false;
    RunReport r;
    if (which[0] == 'u')
      p.run(ro, r);
    else
      run_tiled(p, to, ro, r);
  }
}

}  // namespace terracl::test
