// SPDX-License-Identifier: Apache-2.0
#pragma once
// The state an edit script works on: the gradient field on the device, the hard elevation
// constraints, and the last reconstruction (a cache, also the warm start of the next solve).
#include "authoring/params.hpp"

#include <terracl/reconstruct.hpp>
#include <terracl/tensor.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace terracl::edit {

/// A cell index from a floored/ceiled coordinate in cells, clamped in double before the cast: a
/// point far off the grid (a vertex at 1e11 m) must not overflow int.
inline int cell_index(double v) { return std::isfinite(v) ? int(std::clamp(v, -1e9, 1e9)) : 0; }

/// A region's weight (1 inside, fading over its falloff) on the host, over the box of cells it
/// touches: what operations that work on the host (strata, drainage) read once.
struct HostRegion {
  Box box;
  std::vector<float> w;  ///< box.w x box.h, row by row
  bool contains(int x, int y) const { return x >= box.x0 && y >= box.y0 && x < box.x0 + box.w && y < box.y0 + box.h; }
  /// Index into box-sized arrays (the cell must be in the box).
  size_t at(int x, int y) const { return size_t(y - box.y0) * box.w + (x - box.x0); }
  /// The weight at a grid cell, 0 outside the box.
  double weight(int x, int y) const { return contains(x, y) ? double(w[at(x, y)]) : 0.0; }
};

class EditState {
 public:
  /// `g0` is the starting gradient (its georef, metadata and mean elevation are kept);
  /// `h0` the matching heightfield when known (becomes the first warm start).
  EditState(Device& d, const GradientField& g0, std::optional<Heightfield> h0, SolverOptions solver);

  /// A deep copy that continues exactly as this state would: the field and scratch buffers are
  /// copied on the device (clEnqueueCopyBuffer), everything else (constraints, solution, stale
  /// flag, solver options, last solve, solve count, log, locality, lakes) on the host. Applying
  /// the same operations to the copy and to this state gives bit-identical terrains. Device
  /// memory: 20 bytes a cell (gx, gy, tx, ty, mask; 32 once noise allocated nv, nx, ny); host
  /// memory: about 28 bytes a cell (download cache, constraints, solution, base and its field),
  /// plus the water layer when lakes were filled.
  std::unique_ptr<EditState> clone() const;

  Device& device() { return m_device; }
  const Grid& grid() const { return m_grid; }
  void set_unit(double metres_per_unit) { m_grid.unit = metres_per_unit; }
  GradientBuffers& buffers() { return m_buf; }

  /// Hard elevation constraints, row-major, NaN for free cells. Later constraints replace earlier
  /// ones (elevation constraints do not superpose).
  std::vector<float>& hard() { return m_hard; }
  size_t hard_count() const;
  void set_hard(size_t i, float z) { m_hard[i] = z; }
  void clear_hard();

  /// Call after every change of the gradient or of the constraints.
  void changed() { m_stale = m_field_changed = true; }
  bool stale() const { return m_stale; }
  /// Declares the cached solution consistent with the field again (after regularize).
  void mark_fresh() { m_stale = false; }
  /// The current terrain: reconstructs (warm-started from the last solution) when stale.
  const Heightfield& height();
  /// Reconstructs now, even when not stale; warm: start from the last solution.
  const Heightfield& solve(bool warm = true);
  const ReconstructResult& last_solve() const { return m_last; }
  /// The last reconstruction (on a real base, the base until the first solve), even when stale;
  /// nullptr before any. For estimates that must not cost a solve (a crest's default height).
  const Heightfield* last_solution() const { return m_solution ? &*m_solution : nullptr; }
  int solves() const { return m_solves; }

  /// The gradient field on the host (georef, metadata and mean elevation of the start): a copy.
  GradientField download();
  /// The same into the state's own copy (m_template), with no new 8-byte-a-cell block: a fresh
  /// one costs its page faults (17-25 ms at 1025^2, more than the copy).
  const GradientField& sync_field();
  void upload(const GradientField& g);
  /// Mean elevation reconstruction keeps when no cell is hard.
  void set_mean(double m) { m_template.mean_elevation = m; }

  // ---- landform detail (landform_detail.hpp) ----
  /// Whether landform strokes draw dictionary detail (off in the studio's coarse previews, where
  /// the grid is a sample and the detail would be lost anyway).
  bool landform_detail() const { return m_landform_detail; }
  void set_landform_detail(bool on) { m_landform_detail = on; }
  /// The terrain the state started from when it has relief (a real base: the exemplar of the
  /// "local" style); nullptr on a level base.
  const std::shared_ptr<const Heightfield>& start_terrain() const { return m_start; }
  /// A painted style region (the `style` operation): later strokes inside it take its detail.
  struct StyleLayer {
    std::string style;
    HostRegion region;
  };
  void add_style(StyleLayer l) { m_styles.push_back(std::move(l)); }
  const std::vector<StyleLayer>& styles() const { return m_styles; }

  /// Per-operation log (JSON objects), written into the edit report.
  nlohmann::json& log() { return m_log; }

  /// The elevation change of the erode operations so far (bed after minus terrain before, summed
  /// over them; metres, row-major); empty before the first one. Exports' wear and deposition masks.
  const std::vector<float>& erosion_change() const { return m_erosion_change; }
  void add_erosion_change(const Heightfield& before, const Heightfield& after) {
    if (m_erosion_change.empty()) m_erosion_change.assign(before.z.size(), 0.f);
    for (size_t i = 0; i < m_erosion_change.size(); ++i) m_erosion_change[i] += after.z[i] - before.z[i];
  }

  // ---- locality (docs/authoring.md, "Locality") ----
  /// Local solves: only the cells within the falloff of the changed cells move (the change is
  /// solved there with the unchanged terrain as Dirichlet border); every other cell keeps the base
  /// elevation bit for bit. Off: the global Poisson solve of the whole field.
  void set_local(bool on) {
    if (on != m_local) m_stale = true;
    m_local = on;
  }
  bool local() const { return m_local; }
  /// Falloff distance (metres) of local solves; nullopt: kFalloffPerReach x the largest reach
  /// noted, at least kMinFalloffCells cells.
  void set_falloff(std::optional<double> metres) {
    m_falloff = metres;
    m_stale = true;
  }
  void note_reach(double metres) { m_reach = std::max(m_reach, metres); }
  /// An operation's support: cells [x0, x1] x [y0, y1] (the points it read grown by its reach, or
  /// the whole grid) and its reach (metres); its changed cells fade over kFalloffPerReach x reach.
  struct Support {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    double reach = 0;
  };
  void note_support(const Support& s) {
    m_supports.push_back(s);
    m_stale = true;
  }
  double falloff() const;
  /// The current solution and field become the base of later local solves (regularize bakes
  /// the edits into the gradient).
  void rebase();
  /// What the last solve did: mode, falloff, changed / solved cells, window (JSON).
  const nlohmann::json& locality_report() const { return m_locality; }

 private:
  void solve_local(bool warm);
  void solve_global(bool warm);
  void keep_far_field_level();

  Device& m_device;
  Grid m_grid;
  GradientBuffers m_buf;
  GradientField m_template;
  std::vector<float> m_hard;
  std::optional<Heightfield> m_solution;
  bool m_stale = true;
  SolverOptions m_solver;
  ReconstructResult m_last;
  int m_solves = 0;
  nlohmann::json m_log = nlohmann::json::array();
  std::vector<float> m_erosion_change;
  // Locality: the base terrain and its gradient (host copies), the falloff and the report.
  bool m_local = false;
  std::optional<double> m_falloff;
  double m_reach = 0;
  std::vector<Support> m_supports;
  Heightfield m_base;
  std::vector<float> m_base_gx, m_base_gy;
  nlohmann::json m_locality = nlohmann::json::object();
  bool m_landform_detail = true;
  std::vector<uint8_t> m_scratch_changed, m_scratch_covered, m_scratch_omega;  // solve_local's
  std::vector<float> m_scratch_wt;
  /// False while m_template's gradient is the device field (a local solve just downloaded it).
  bool m_field_changed = true;
  std::shared_ptr<const Heightfield> m_start;
  std::vector<StyleLayer> m_styles;

 public:
  // ---- lakes (lake.cpp; docs/authoring.md, "Lakes") ----
  /// A lake operation: water filling the basin around a seed cell up to a level. Only the
  /// definition is kept: the water is computed from the terrain when asked, so operations after
  /// the lake that change the terrain move its shore.
  struct Lake {
    enum Rule { Spill, Level, Depth } rule = Spill;
    double value = 0;  ///< Level: metres; Depth: metres of water at the seed
    int sx = 0, sy = 0;  ///< the seed cell
    std::string path;    ///< JSON path of the seed, for warnings
    size_t log_index = 0;  ///< its entry in log()
    std::vector<std::string> parse_warnings;
  };
  /// Records a lake; the terrain is not changed (no gradient, no constraint, no re-solve).
  void add_lake(Lake l) { m_lakes.push_back(std::move(l)); }
  bool has_lakes() const { return !m_lakes.empty(); }
  /// Water depth (metres, >= 0, never NaN) of every lake on the current terrain (reconstructs
  /// when stale); where lakes overlap the highest water surface wins. Cached until the next solve
  /// or lake. nullptr when no lake was added. Also writes each lake's figures into its log entry.
  const Heightfield* water();
  /// Per-lake figures of water() (index, level_m, cells, area_m2, volume_m3, max_depth_m, ...).
  const nlohmann::json& lakes_report() {
    water();
    return m_lake_report;
  }

 private:
  std::vector<Lake> m_lakes;
  std::optional<Heightfield> m_water;
  int m_water_solves = -1;  ///< m_solves when m_water was computed
  size_t m_water_lakes = 0;
  nlohmann::json m_lake_report = nlohmann::json::array();
};

/// One parsed operation, ready to run.
using Operation = std::function<void(EditState&)>;

struct OpSpec {
  std::string name;
  std::string summary;
  /// Validates the parameters (throwing with their JSON path) and returns the operation.
  std::function<Operation(Params&)> parse;
  /// False for operations that only add a layer over the terrain (lake): they note no support, so
  /// appending one costs no re-solve and leaves the terrain's bits alone.
  bool changes_terrain = true;
};

/// Every edit operation, in documentation order.
const std::vector<OpSpec>& operations();

// Registration, one function per module.
void add_brush_ops(std::vector<OpSpec>& ops);      // ops_brush.cpp
void add_curve_ops(std::vector<OpSpec>& ops);      // ops_curves.cpp
void add_composite_ops(std::vector<OpSpec>& ops);  // ops_composite.cpp
void add_paste_ops(std::vector<OpSpec>& ops);      // ops_paste.cpp
void add_fit_ops(std::vector<OpSpec>& ops);        // ops_fit.cpp
void add_amplify_ops(std::vector<OpSpec>& ops);    // ops_amplify.cpp
void add_strata_ops(std::vector<OpSpec>& ops);     // ops_strata.cpp
void add_drainage_ops(std::vector<OpSpec>& ops);   // ops_drainage.cpp
void add_landform_ops(std::vector<OpSpec>& ops);   // ops_landforms.cpp
void add_lake_ops(std::vector<OpSpec>& ops);       // ops_lake.cpp
void add_style_ops(std::vector<OpSpec>& ops);      // ops_style.cpp

// ---- geometry shared by the operations (metres, cell (x, y) at (x * cell_x, y * cell_y)) ----

/// A region: a disc (center + radius), a polygon, a painted path (the band swept by a disc of
/// `radius` along the polyline `path`), or the whole grid.
struct Region {
  enum Kind { Everywhere, Disc, Polygon, Path } kind = Everywhere;
  Vec2 center;
  double radius = 0;
  std::vector<Vec2> polygon;
  std::vector<Vec2> path;
  /// Distance (metres) from (x, y) to the disc or the path's band (0 inside); polygons: 0 inside,
  /// infinity outside.
  double distance(double x, double y) const;
};
/// Reads "center" + "radius" (a disc), or "polygon", or "path" + "radius" (a painted stroke), or
/// none of them (`allow_everywhere`).
Region parse_region(Params& p, bool allow_everywhere);
/// The region as a skeleton primitive (falloff `falloff` metres beyond it); Everywhere: a polygon
/// around the grid.
Primitive region_primitive(const Region& r, const Grid& g, double falloff);
/// The region (falloff `falloff` metres) evaluated on the device and read back; an empty box (and
/// no weights) when it touches no cell.
HostRegion region_on_host(EditState& s, const Region& r, double falloff);
/// Indices of the cells whose centre lies inside the region.
std::vector<size_t> region_cells(const Region& r, const Grid& g);

/// Sets every cell whose centre lies within max(width/2, half a cell) of the polyline to the z of
/// the nearest point of the curve (z interpolated along the curve).
void rasterize_polyline(EditState& s, const std::vector<Vec3>& pts, double width);

std::vector<Vec2> xy(const std::vector<Vec3>& pts);
/// Converts a user angle (degrees counter-clockwise from east on a north-up map) to the grid frame
/// (y south), where the kernels measure angles.
inline double grid_angle(double user_rad) { return -user_rad; }

/// RMS of the discrete curl (1/m) of a staggered gradient over the interior faces.
double curl_rms(const GradientField& g);

}  // namespace terracl::edit

namespace terracl {
struct NoiseParams;
}
namespace terracl::edit {
/// Reads a noise block {type, amplitude, wavelength, octaves, lacunarity, gain, seed} and checks
/// that it has no other keys (ops_brush.cpp).
NoiseParams parse_noise_block(Params& p, std::optional<double> def_amp, std::optional<double> def_wavelength,
                              const std::string& def_type);
}  // namespace terracl::edit
