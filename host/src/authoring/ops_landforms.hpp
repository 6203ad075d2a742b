// SPDX-License-Identifier: Apache-2.0
#pragma once
// The relative forms of crest, river and cliff (ops_curves.cpp hands them over when a stroke has
// no `elevation` and no per-vertex z): placed relative to the terrain under them.
#include "authoring/state.hpp"

#include <string>

namespace terracl::edit {

/// True when the operation gives neither `elevation` nor [x, y, z] points under `key`.
bool is_relative(Params& p, const std::string& key);

/// A crest `height` above the ground (default from the relief around it), with short spurs.
Operation relative_crest(Params& p);
/// A valley `depth` below the ground whose bed never rises downstream.
Operation relative_river(Params& p);
/// An escarpment: a plateau `drop` above the ground on the high side, a banded cliff, an apron.
Operation relative_cliff(Params& p);

}  // namespace terracl::edit
