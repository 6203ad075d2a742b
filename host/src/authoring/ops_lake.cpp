// SPDX-License-Identifier: Apache-2.0
// The "lake" operation: water filling the basin around a seed up to a level (its spill point by
// default), kept as a water-depth layer over the terrain; the terrain itself is not changed
// (docs/authoring.md, "Lakes"). The water is computed from the script's final terrain
// (EditState::water, lake.cpp); parsing only fixes the seed cell and the level rule.
#include "authoring/state.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <cmath>

namespace terracl::edit {

namespace {

Operation parse_lake(Params& p) {
  const Grid& g = p.grid();
  EditState::Lake l;
  const Vec2 seed = p.point("seed");
  l.path = p.where("seed");
  // The cell whose centre is nearest; a seed must name a cell (the water starts there), so unlike
  // a stroke's points it may not lie off the grid.
  const double fx = std::floor(seed.x / g.cell_x + 0.5), fy = std::floor(seed.y / g.cell_y + 0.5);
  if (!(fx >= 0 && fx < g.width && fy >= 0 && fy < g.height))
    param_error(l.path, fmt::format("expected a point on the {}x{} grid (x -{:g}..{:g} m, y -{:g}..{:g} m from the centre "
                                    "of cell (0, 0)), got x {:.6g} m, y {:.6g} m{}",
                                    g.width, g.height, 0.5 * g.cell_x, (g.width - 0.5) * g.cell_x, 0.5 * g.cell_y,
                                    (g.height - 0.5) * g.cell_y, seed.x, seed.y,
                                    g.map ? " (map coordinates converted through the base's geotransform)" : ""));
  l.sx = int(fx), l.sy = int(fy);
  if (p.has("level") && p.has("depth"))
    param_error(p.where("depth"), "give either \"level\" (the water surface's elevation) or \"depth\" (the water's "
                                  "depth at the seed), not both");
  if (p.has("level") && p.raw("level").is_string() && p.raw("level") == "spill") {
    l.rule = EditState::Lake::Spill;
  } else if (p.has("level")) {
    l.rule = EditState::Lake::Level;
    try {
      l.value = p.vlength("level");
    } catch (const Error&) {  // vlength's message does not know about "spill"
      param_error(p.where("level"), fmt::format("expected \"spill\" or an elevation in metres (a number, or a string "
                                                "like \"350 m\"), got {}",
                                                p.raw("level").dump()));
    }
  } else if (p.has("depth")) {
    l.rule = EditState::Lake::Depth;
    l.value = p.vlength("depth");
    if (!(l.value > 0)) param_error(p.where("depth"), fmt::format("expected a depth > 0 m, got {:g} m", l.value));
  }
  return [l](EditState& s) mutable {
    nlohmann::json& entry = s.log().back();
    l.log_index = s.log().size() - 1;
    if (entry.contains("warnings")) l.parse_warnings = entry["warnings"].get<std::vector<std::string>>();
    entry["seed_cell"] = {l.sx, l.sy};
    s.add_lake(std::move(l));  // no s.changed(): the terrain stays as it is
  };
}

}  // namespace

void add_lake_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"lake",
                 "water filling the basin around a seed up to a level (default: its spill point), written as a water-depth "
                 "layer; the terrain is not changed",
                 parse_lake, false});
}

}  // namespace terracl::edit
