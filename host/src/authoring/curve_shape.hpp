// SPDX-License-Identifier: Apache-2.0
#pragma once
// The cross-section and path options shared by the landform curves (ops_curves.cpp) and the
// mountain_range brush (ops_composite.cpp): width, profile, floor, taper, smoothing.
#include "authoring/state.hpp"

#include <string>
#include <vector>

namespace terracl::edit {

struct CurveShape {
  std::vector<Vec3> pts;   ///< as given (z NaN when absent)
  double radius = 0;       ///< half-width r in metres; 0: the default (resolve_radius)
  double floor = 0;        ///< width of a flat floor/top (metres); constrained band of crest/cliff/river
  double taper = 0;        ///< taper length at both ends (metres); -1: the half-width
  bool smooth = false;     ///< centripetal Catmull-Rom through the points
  bool flat = false;       ///< "profile": "flat" (U with a floor of 2/3 of the width by default)
  Profile profile = Profile::Round;

  /// r, or the default max(min_half_width, per_metre * |amplitude|).
  double resolve_radius(const Grid& g, double amplitude, double per_metre) const;
  /// The polyline to use: the points, or the Catmull-Rom spline through them (pieces <= r/4).
  std::vector<Vec3> path(const Grid& g, double r) const;
  Primitive primitive(const std::vector<Vec3>& path_pts, double r, Profile prof, double amplitude) const;
};

/// Reads points, width|radius, floor, profile (one of `profiles`, none when empty), taper (default:
/// the half-width when `def_taper`, else none) and smooth.
CurveShape parse_curve_shape(Params& p, const std::string& def_profile, const std::vector<std::string>& profiles,
                             bool def_taper);
/// The smallest default half-width: 9 cells (every default feature is >= 3 cells wide).
double min_half_width(const Grid& g);
/// Frees the hard cells within `half` metres of the polyline (a ravine cutting a rim).
void release_near_polyline(EditState& s, const std::vector<Vec3>& pts, double half);

}  // namespace terracl::edit
