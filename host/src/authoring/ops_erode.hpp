// SPDX-License-Identifier: Apache-2.0
#pragma once
// The "erode" edit operation: virtual-pipe erosion (terracl/erosion.hpp) of the current terrain,
// baked back into the gradient field. Shared with the studio's live erosion preview so that the
// preview and the recorded operation run the same simulation.
#include <terracl/erosion.hpp>

#include "authoring/state.hpp"

namespace terracl::edit {

struct ErodeSpec {
  ErosionParams params;
  int steps = 0;
  Region region;       ///< Everywhere, a disc or a polygon (the erosion brush)
  double falloff = 0;  ///< m, the brush's weight fades to 0 over this distance outside the region
};

ErodeSpec parse_erode_spec(Params& p);
/// Per-cell weight in [0, 1]: the brush (1 inside, a smooth fade over `falloff` outside), 0 on hard
/// cells (`hard`: NaN = free) so constraints stay exact.
std::vector<float> erode_weight(const ErodeSpec& e, const Grid& g, const std::vector<float>& hard);

void add_erode_ops(std::vector<OpSpec>& ops);

}  // namespace terracl::edit
