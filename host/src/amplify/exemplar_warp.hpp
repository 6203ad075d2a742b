// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to the amplify module: the exemplar warp of `amplify --resample-exemplar`.
#include <terracl/heightfield.hpp>

#include <string>

namespace terracl {

/// GDAL warp (averaging) of `exemplar` to cells of cell_x x cell_y metres, in `target`'s CRS when
/// both CRSs are known and differ (else in the exemplar's own). Throws, naming `name`, when the
/// exemplar is coarser than the cells asked for or has no georeferencing. Cells the warp leaves
/// empty are filled (harmonic).
Heightfield resample_exemplar(const Heightfield& exemplar, const Georef& target, double cell_x, double cell_y,
                              const std::string& name);

}  // namespace terracl
