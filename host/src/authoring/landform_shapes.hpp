// SPDX-License-Identifier: Apache-2.0
#pragma once
// The landforms a stroke makes (ops_landforms.cpp parses them): each returns its change of
// elevation as a magnitude >= 0 over the cells it touches (a lowering landform's caller negates
// it). The layout rules (spurs per summit, side canyons, cliff bands and chutes, radial gullies)
// live here, drawn from `seed`, so one stroke makes the whole structure.
#include "authoring/landform.hpp"

#include <functional>

namespace terracl::edit {

/// Common knobs, each in [0, 1]: roughness (detail and how far lines wander) and age (young:
/// sharp crests, steep walls; old: lower, rounded, smoothed, less fine detail).
struct LandformLook {
  double roughness = 0.5;
  double age = 0.3;
  uint32_t seed = 1;
};

/// A ridge system along a stroke: the main crest (summits and saddles along it), spurs branching
/// from it down both flanks (and spurs of spurs), with half-width `width` (m) and crest `height`
/// (m) scaled per vertex by `scale` (size 1 or one per stroke vertex). `spurs` in [0, 2] scales
/// their number (0: a single crest). A one-point stroke is a peak with spurs all around.
struct RidgeParams {
  std::vector<Vec2> stroke;
  std::vector<double> height;  ///< per stroke vertex (or one value)
  double width = 0;            ///< half-width of the footprint (m)
  double spurs = 1;
  double taper = -1;  ///< metres over which the ends fade; < 0: the default (about a half-width)
  double sharpness = -1;  ///< crest profile in [0, 1]; < 0: from age
  /// A range's crest wanders and rises and falls in summits and saddles; a crest keeps the line
  /// and the height it was drawn with.
  bool free_line = true;
  LandformLook look;
};
ShapeRaster ridge_system(const Grid& g, const RidgeParams& p);

/// A volcano: a concave cone with a summit crater and radial ridges and gullies.
struct VolcanoParams {
  Vec2 center;
  double height = 0, radius = 0;  ///< m
  double crater = 0.2;            ///< crater radius / radius (0: none)
  LandformLook look;
};
ShapeRaster volcano(const Grid& g, const VolcanoParams& p);

/// A valley along a stroke (river, canyon): its depth below the ground (per resampled vertex, from
/// `depth_at(arc)`), a floor and walls, side valleys joining it, and for a canyon walls in bands
/// of hard and soft rock (benches and cliffs of uneven thickness). Returns the magnitude (>= 0).
struct ValleyParams {
  std::vector<Vec2> stroke;
  std::function<double(const Vec2&, double arc, double length)> depth_at;
  double width = 0;         ///< half-width at the rim (m)
  /// The valley's own depth (m; 0: unknown). Where `depth_at` is deeper (a gorge through rising
  /// ground), the valley widens, up to 4 times, so that its walls are no steeper than their own
  /// slope or `wall_tan` (a tangent), whichever is steeper.
  double depth = 0, wall_tan = 0;
  double floor = 0.2;       ///< floor half-width / width
  int bands = 0;            ///< rock bands in the walls (0: a smooth wall)
  double branches = 1;      ///< side valleys per length, scale in [0, 2]
  double meander = 0.2;     ///< lateral wander / width
  /// The ground the valley is cut into (cells of `g`), or none. With it each piece's bed is an
  /// elevation (the ground under its vertex less its depth there) and a cell is lowered by its own
  /// height above that bed times the cross-section's share, so it never goes below the bed and
  /// cells already below it stay; without it every cell is lowered by the vertex's depth.
  const Heightfield* ground = nullptr;
  /// With `ground`: where given, each cell's depth down to its bed (0: outside every piece), so
  /// that detail added afterwards can be kept above the beds too.
  ShapeRaster* to_bed = nullptr;
  LandformLook look;
};
ShapeRaster valley_system(const Grid& g, const ValleyParams& p);

/// An escarpment: a plateau behind the stroke (on `left` of its direction, else right) that ends
/// at a cliff of `drop` metres, in bands, notched by chutes, above a talus apron; the plateau's
/// back slope fades to the ground over `back` metres.
struct EscarpmentParams {
  std::vector<Vec2> stroke;
  double drop = 0, back = 0;
  bool left = false;
  int bands = 3;
  double talus = 0.35;  ///< apron height / drop
  LandformLook look;
};
ShapeRaster escarpment(const Grid& g, const EscarpmentParams& p);

}  // namespace terracl::edit
