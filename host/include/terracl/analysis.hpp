// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Terrain analysis on the host: depression filling and breaching, flow routing (D8, D-infinity),
/// realism statistics and sketch extraction. All lengths are metres and all areas square metres,
/// from the heightfield's metric cell size (georef.cell_x along a row, cell_y along a column).
///
/// Conventions shared by every function here:
/// - Cells are indexed i = y * width + x, row 0 north. NaN cells (nodata) stay NaN; a valid cell
///   next to a nodata cell or on the raster border is an outlet where water leaves the grid.
/// - Neighbour k (0..7) is E, SE, S, SW, W, NW, N, NE (kDx/kDy below); ties are always broken by
///   the lowest k, so results are deterministic.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>
#include <array>
#include <vector>

namespace terracl::analysis {

/// D8 neighbour offsets by direction code 0..7: 0 = east, then clockwise on the map (y grows south).
constexpr int kDx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr int kDy[8] = {0, 1, 1, 1, 0, -1, -1, -1};
/// Flow direction codes besides 0..7: water leaves the grid here / nodata cell.
constexpr uint8_t kOutlet = 8;
constexpr uint8_t kNoFlow = 255;

// ---------------------------------------------------------------------------------------------
// Depressions

/// Result of Priority-Flood filling (Barnes, Lehman, Mulla 2014).
struct FillResult {
  Heightfield filled;       ///< the filled surface (same georef)
  double volume_m3 = 0;     ///< sum of raised depths times the cell area
  double max_depth_m = 0;   ///< largest raised depth
  size_t cells_raised = 0;  ///< cells whose elevation changed
};

/// Fills every depression to its spill level, so that each cell has a non-ascending path to an
/// outlet. With `epsilon` true (Priority-Flood+epsilon) filled flats get the smallest float
/// increments (std::nextafter) towards their spill point, so every cell has a strictly lower
/// neighbour or is an outlet; the volume then includes those tiny increments.
FillResult priority_flood_fill(const Heightfield& h, bool epsilon = false, const Progress& progress = {});
/// The same, filling `h`'s own cells into the result (no copy of the raster: the flood needs the
/// cells and a byte per cell). The same cells; the statistics are summed in the flood's order, so
/// volume_m3 may differ from the copying overload's in its last bits.
FillResult priority_flood_fill(Heightfield&& h, bool epsilon = false, const Progress& progress = {});

/// Result of complete breaching (Lindsay 2016).
struct BreachResult {
  Heightfield breached;              ///< the breached surface
  double volume_m3 = 0;              ///< b: sum of lowered depths times the cell area
  double mean_depth_m = 0;           ///< b-bar: b divided by the area of all valid cells (metres)
  double mean_depth_breached_m = 0;  ///< mean lowered depth over the lowered cells only
  double max_depth_m = 0;            ///< deepest cut
  size_t cells_lowered = 0;
  double raised_volume_m3 = 0;  ///< single-cell pits raised to their lowest neighbour first
  size_t pits_raised = 0;
};

/// Complete breaching: single-cell pits (strictly below all 8 neighbours) are first raised to their
/// lowest neighbour when `raise_single_cell_pits`; then a priority flood from the outlets records
/// back-links, and whenever it reaches a cell lower than the cell it came from, the back-link path
/// from there is lowered to that cell's level until a cell at or below it (or the outlet).
BreachResult breach_depressions(const Heightfield& h, bool raise_single_cell_pits = true,
                                const Progress& progress = {});

// ---------------------------------------------------------------------------------------------
// Flow routing

/// D8 flow routing on the epsilon-filled surface (so flats and depressions drain).
struct D8Result {
  int width = 0, height = 0;
  std::vector<uint8_t> dir;   ///< 0..7 neighbour, kOutlet (off the grid), kNoFlow (nodata)
  std::vector<double> cells;  ///< accumulation in cells, including the cell itself (0 on nodata)
  double cell_area_m2 = 1;
  double outflow_cells = 0;  ///< accumulation leaving the grid: equals the number of valid cells
  size_t valid_cells = 0;
  double area_m2(size_t i) const { return cells[i] * cell_area_m2; }
};

/// Steepest drop over distance (cell_x, cell_y or the diagonal) to one of the 8 neighbours; a cell
/// with no lower neighbour is an outlet (only border cells and cells next to nodata once filled).
D8Result d8_flow(const Heightfield& h, const Progress& progress = {});

/// D-infinity flow routing (Tarboton 1997) on the epsilon-filled surface.
struct DinfResult {
  int width = 0, height = 0;
  /// Receivers of each cell: neighbour index (0..7, or kOutlet/kNoFlow in `k1`) and the share of
  /// the flow each receives (share1 + share2 = 1; k2 = kNoFlow when everything goes to k1).
  std::vector<uint8_t> k1, k2;
  std::vector<float> share1;
  std::vector<float> angle_rad;  ///< Tarboton's flow angle, counter-clockwise from east; NaN at outlets
  std::vector<double> cells;     ///< accumulation in cells (contributing area / cell area)
  double cell_area_m2 = 1;
  double outflow_cells = 0;
  size_t valid_cells = 0;
};
/// The epsilon fill d8_flow and dinf_flow route, done in place: `h` unchanged when it already
/// drains, else priority_flood_fill(h, true) (nodata stays nodata). Routing the result then makes
/// no copy of the surface.
void fill_for_routing(Heightfield& h, const Progress& progress = {});

/// Tarboton's D-infinity flow directions and accumulation on the metric grid.
DinfResult dinf_flow(const Heightfield& h, const Progress& progress = {});
/// The same, `angle_rad` left empty when `with_angles` is false (4 bytes per cell less).
DinfResult dinf_flow(const Heightfield& h, const Progress& progress, bool with_angles);

// ---------------------------------------------------------------------------------------------
// Statistics

/// Slope in degrees per cell with Horn's 3x3 method (borders: nearest valid value repeated).
std::vector<float> slope_degrees(const Heightfield& h);

/// Realism statistics as a JSON object (see docs/analysis.md for every key): slope distribution,
/// curvature, spectral slope, hypsometric integral, Gini of D8 drainage area, and the fill /
/// breach figures.
nlohmann::json terrain_metrics(const Heightfield& h, const Progress& progress = {});

/// Radially averaged power spectrum slope: the least-squares slope of log P against log k over the
/// resolved wavenumbers (after removing the best-fit plane and a Hann window). Returns NaN for
/// grids smaller than 8x8.
double spectral_slope(const Heightfield& h);

/// Gini coefficient of non-negative values (0: all equal, -> 1: concentrated in one).
double gini(std::vector<double> values);

/// Human-readable summary of a `terrain_metrics` report.
std::string format_metrics(const nlohmann::json& report);

// ---------------------------------------------------------------------------------------------
// Sketch extraction

/// Thresholds of the sketch extraction (`terracl sketch`).
struct SketchOptions {
  double river_fraction = 0.002;  ///< rivers: D8 accumulation >= this fraction of the valid cells
  double ridge_fraction = 0.002;  ///< ridges: the same on the inverted terrain
  int min_cells = 8;              ///< lower bound of both thresholds, in cells
  int window = 15;                ///< peaks/basins: max/min filter size in cells (odd)
  double prominence_m = -1;       ///< max-min difference in the window; < 0: 10 % of the relief
  double smooth_cells = 0;        ///< Gaussian blur sigma in cells before extraction (0: none)
  double simplify_cells = 0.5;    ///< Douglas-Peucker tolerance of the polylines, in cells
  double line_smooth_cells = 3;   ///< Gaussian sigma (cells) along the traced lines against D8's
                                  ///< 0/45-deg staircase (0: the raw D8 paths)
  int patch = 15;                 ///< size of the peak/basin squares in the picture's blue channel
};

/// Rivers and ridges as polylines, peaks and basins as points, and the sketch picture.
struct Sketch {
  struct Point {
    double x, y, z;
  };
  struct Line {
    std::vector<Point> points;  ///< upstream to downstream (rivers), crest to foot end (ridges)
    double drainage_area_m2;    ///< at the last point (rivers) / on the inverted terrain (ridges)
    int strahler = 0;           ///< Strahler order of the segment in the D8 network (heads: 1)
  };
  struct Extremum {
    Point p;
    double relief_m;  ///< max - min in the window around it
  };
  int width = 0, height = 0;
  std::vector<Line> rivers, ridges;
  std::vector<Extremum> peaks, basins;
  /// RGB picture, row-major: R ridges (255), G rivers (255), B peak/basin squares whose value is
  /// the normalised elevation (1..255, the paper's elevation target layer).
  std::vector<uint8_t> rgb;
};
/// Rivers, ridges, peaks and basins of `h` (the inputs of the edit operation `fit`).
Sketch extract_sketch(const Heightfield& h, const SketchOptions& opt = {}, const Progress& progress = {});

/// The JSON document described in docs/analysis.md ("terracl-sketch", version 1).
nlohmann::json sketch_to_json(const Sketch& s, const Heightfield& h);
/// The points (and multipoints) of the first layer of an OGR vector file, in the CRS of `g` (transformed
/// from the layer's when both are known); UsageError naming the file otherwise.
std::vector<std::array<double, 2>> read_pour_points(const std::string& path, const Georef& g);
/// Whether `path` names a vector file write_sketch_vectors writes (.geojson, .gpkg, .kml).
bool is_sketch_vector_path(const std::string& path);
/// Rivers and ridges (3-D lines), peaks and basins (points) as one layer "sketch" with fields kind,
/// drainage_area_m2, elevation_m, relief_m, in map coordinates of `h` (GeoJSON: WGS 84 per RFC 7946),
/// written atomically through OGR.
void write_sketch_vectors(const Sketch& s, const Heightfield& h, const std::string& path);

}  // namespace terracl::analysis
