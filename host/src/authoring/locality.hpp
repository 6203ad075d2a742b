// SPDX-License-Identifier: Apache-2.0
#pragma once
// Locality of edits on a base DEM (docs/authoring.md, "Locality"): which cells an edit changed,
// the region grown by the falloff, and the distance transform behind it.
#include <cstdint>
#include <vector>

namespace terracl::edit {

/// Squared Euclidean distance (m^2) from every cell of a w x h grid to the nearest cell with
/// src != 0 (cells of cx x cy metres); +inf everywhere when no cell is set. Exact (separable
/// lower-envelope transform of Felzenszwalb and Huttenlocher), O(w h).
std::vector<float> squared_distance(const std::vector<uint8_t>& src, int w, int h, double cx, double cy);

/// Falloff defaults: the change fades to zero over this many times the largest reach (radius,
/// region falloff, half width...) of the script's operations beyond the cells they changed, and
/// over at least kMinFalloffCells cells.
constexpr double kFalloffPerReach = 3.0;
constexpr double kMinFalloffCells = 8.0;

}  // namespace terracl::edit
