// SPDX-License-Identifier: Apache-2.0
#pragma once
// Landforms: a stroke becomes a change of elevation computed on the host (a raster over the box it
// touches) and added to the field as its exact discrete gradient, so the solve reproduces
// terrain + change. A raising landform's change is clamped to >= 0 and a lowering one's to <= 0:
// whatever the parameters, it never moves land against its sign (no moat beside a ridge, no lobe
// beside a valley), and cells outside its footprint keep their elevation.
//
// The shapes are built from a skeleton (ridge lines with a height and a half-width per vertex,
// unioned by max, as a range's spurs stand out of its flanks) and carry detail at every scale the
// grid resolves (fractal noise whose amplitude follows the local relief), so no line is ruled
// straight and no flank is smooth.
#include "authoring/state.hpp"

#include <cstdint>
#include <limits>
#include <vector>

namespace terracl::edit {

/// Values on the cells of `box` (row by row); 0 outside it.
struct ShapeRaster {
  Box box;
  std::vector<float> v;
  ShapeRaster() = default;
  explicit ShapeRaster(const Box& b) : box(b), v(size_t(std::max(0, b.w)) * size_t(std::max(0, b.h)), 0.0f) {}
  float& at(int x, int y) { return v[size_t(y - box.y0) * box.w + (x - box.x0)]; }
  float at(int x, int y) const { return v[size_t(y - box.y0) * box.w + (x - box.x0)]; }
  bool contains(int x, int y) const { return x >= box.x0 && y >= box.y0 && x < box.x0 + box.w && y < box.y0 + box.h; }
};

/// The box of cells within `margin` metres of the points, clipped to the grid.
Box box_around(const Grid& g, const std::vector<Vec2>& pts, double margin);

/// Adds the staggered gradient of `change` (metres, 0 outside its box) to the field. `sign` > 0
/// clamps it to >= 0 first, < 0 to <= 0, 0 leaves it. Hard cells under the change move with it
/// (a pinned cell stays consistent with the field around it). Returns the clamped change.
const ShapeRaster& add_change(EditState& s, ShapeRaster& change, int sign);

/// The current terrain without a new solve: the last solution (the base before the first solve).
/// An estimate that misses the operations queued since the last solve.
const Heightfield& terrain_estimate(EditState& s);
/// Bilinear sample of the terrain estimate at (x, y) metres (clamped to the grid).
double terrain_at(EditState& s, double x, double y);
/// `h` (cells of `g`) at the point (x, y) metres, bilinear, clamped to the grid.
double sample_at(const Heightfield& h, const Grid& g, double x, double y);
/// The ground within `radius` metres of the points' bounding box, from the terrain estimate.
struct GroundAround {
  double relief = 0;      ///< p95 - p05 of the elevations (m)
  double steep_tan = 0;   ///< p90 of the slopes, as a tangent (0 on a level base)
};
GroundAround ground_around(EditState& s, const std::vector<Vec2>& pts, double radius);

// ---- randomness and noise on the host (deterministic across platforms) ----

/// A small counter-based generator: the same seed gives the same landform everywhere.
class Rng {
 public:
  explicit Rng(uint64_t seed) : m_s(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull) {}
  uint64_t next();
  /// Uniform in [0, 1).
  double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  uint64_t m_s;
};

/// Lattice gradient noise in about [-1, 1] (2-D; use y = const for a 1-D signal).
double gradient_noise(double x, double y, uint32_t seed);
/// Sum of `octaves` octaves (wavelength halves, amplitude `gain` times per octave), first at
/// wavelength 1, normalised so that the sum stays in about [-1, 1].
double fbm(double x, double y, int octaves, double gain, uint32_t seed);
/// Ridged multifractal variant in about [-1, 1]: sharp crests, rounded troughs.
double ridged(double x, double y, int octaves, double gain, uint32_t seed);
/// Octaves from `wavelength` down to the finest one the grid resolves (>= 2.5 cells).
int octaves_down_to_cells(double wavelength, double cell);

// ---- stroke geometry ----

/// The polyline resampled every <= `step` metres (vertices kept).
std::vector<Vec2> resample(const std::vector<Vec2>& pts, double step);
/// Arc length at each vertex.
std::vector<double> arc_lengths(const std::vector<Vec2>& pts);
/// Displaces each vertex along the local normal by multi-scale noise: amplitude `amp` metres at
/// wavelength `wavelength` (arc length), halving with it over `octaves`; the ends move less so the
/// stroke still starts and ends where it was drawn. Keeps a hand-drawn line from reading as ruled.
std::vector<Vec2> wander(const std::vector<Vec2>& pts, double amp, double wavelength, int octaves, uint32_t seed);

/// A ridge line of the skeleton: per-vertex crest height (m) and half-width (m).
struct RidgeLine {
  std::vector<Vec2> pts;
  std::vector<double> h, w;
};
/// out = max(out, h(t) * profile(d / w(t))) over the cells near every piece of the line; profile
/// is 1 at the crest and 0 at d = w, `sharpness` in [0, 1] blends a rounded top (0) into a sharp,
/// concave flank (1).
void max_ridge(ShapeRaster& out, const Grid& g, const RidgeLine& line, double sharpness);

/// Multiplies the shape by (1 + amp * noise) with fractal detail from `wavelength` down to the
/// grid's resolution (ridged noise, oriented by nothing: the shape's own spurs carry direction),
/// and warps nothing: the detail's amplitude follows the shape, so it vanishes where the shape does.
/// Above `cap` metres of shape the amplitude stays that of `cap` (a gorge keeps its valley's detail).
void add_relief_detail(ShapeRaster& shape, const Grid& g, double amp, double wavelength, uint32_t seed,
                       double cap = std::numeric_limits<double>::infinity());

}  // namespace terracl::edit
