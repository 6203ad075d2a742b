// Shape facts of the gallery examples (data/examples/), checked on their runs by
// test_edit_examples.cpp: edit_example_landforms.cpp holds the strokes' geometry and the cliff and
// mountain-range checks, edit_example_checks.cpp the per-example checks.
#pragma once

#include <terracl/edit.hpp>
#include <terracl/tensor.hpp>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace terracl::test::examples {

/// Height at (x, y) metres from the centre of cell (0, 0), bilinear (clamped to the grid).
double at_m(const Heightfield& h, double cell, double x, double y);

struct Stroke {
  double mx, my, nx, ny;  // a point on the curve and the unit normal there
};
/// The middle vertex of a stroke with an odd number of points (a smoothed stroke passes through it),
/// else the middle of the middle segment; the normal from the neighbouring points.
Stroke middle_of(const nlohmann::json& pts);

/// The canyon's side canyons where they cut the rims: stations every 20 m along each smoothed cliff
/// rim (the cliffs' points through catmull_rom), 200 m or more inside the map, where the terrain lies
/// >= 250 m below the cliff's `elevation`; runs of such stations closer than 60 m are one cut.
struct RimCut {
  std::vector<Vec2> stations;
  double lowest = 1e30;
  int rim = 0;  // which cliff (0, 1, ...)
  double width() const { return 20.0 * double(stations.size()); }
};
std::vector<RimCut> canyon_cuts(const nlohmann::json& script, const Heightfield& h, double cell);

/// Inside a polygon (even-odd rule).
bool in_polygon(const nlohmann::json& poly, double x, double y);

/// The cliff example turned a quarter (plateau north of a west-east cliff), then checked.
bool check_turned_cliff(const nlohmann::json& script, const Heightfield& h, double cell);
/// The cliff band reads as natural rock: irregular gullies along the brink, a plateau with relief.
void check_cliff_band(const nlohmann::json& op, const Heightfield& h, double cell);
/// The mountain range's ravines form a dendritic network that drains.
void check_range_network(const nlohmann::json& script, const Heightfield& h, double cell);

/// Every shape fact of example `name` on its run `h` (cell size `cell` of the run).
void check_shapes(const std::string& name, const nlohmann::json& script, const Heightfield& h, double cell);
/// The river valley opens onto the plains, has a flood-plain floor and falls downstream.
void check_river_valley(const nlohmann::json& script, const Heightfield& h);

}  // namespace terracl::test::examples
