// SPDX-License-Identifier: Apache-2.0
#pragma once
// Lakes on a terrain (docs/authoring.md, "Lakes"): the spill level of the basin around a seed
// cell and the cells a lake at a given level covers. Host code on a Heightfield; 4-connected
// throughout, so the spill level and the lake agree (a lake at its spill level never leaks past
// the saddle).
#include <terracl/heightfield.hpp>

#include <cstddef>
#include <vector>

namespace terracl::edit {

/// Where the water poured at a seed collects and overflows.
struct SpillPoint {
  double level = 0;     ///< metres: the lowest level at which the water overflows
  int pit_x = 0, pit_y = 0;  ///< the lowest cell the water runs down to from the seed
  int x = 0, y = 0;     ///< the outlet cell: the saddle, or the grid edge cell the water leaves by
  bool edge = false;    ///< the water leaves the grid (rather than falling into another basin)
};

/// The water first runs down from the seed (to the lowest 4-neighbour, while one is lower) to the
/// bottom of its depression; a priority flood from there, lowest cell first, raises the water
/// level to the highest cell flooded so far, and the depression overflows when the flood next
/// reaches a cell lower than that level (another basin) or a cell on the grid's edge (the water
/// leaves the map). A depression that holds nothing (a flat that drains, a slope to the edge)
/// spills at its lowest cell's elevation: an empty lake. Non-finite cells are walls.
SpillPoint spill_point(const Heightfield& h, int sx, int sy);

/// Indices of the cells with elevation < level that are 4-connected to the seed through such
/// cells, in visiting order; empty when the seed itself is not below the level.
std::vector<size_t> lake_cells(const Heightfield& h, int sx, int sy, double level);

}  // namespace terracl::edit
