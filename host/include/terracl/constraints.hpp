// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Hard elevation constraints (Dirichlet cells) for reconstruction, and their rasterisation from
/// points, polylines, polygons, mask/elevation rasters and constraint JSON files.
///
/// Priority rule when several constraints hit one cell: the more specific kind wins,
///   Point > Polyline > Polygon > Raster,
/// and constraints of the same kind on one cell are averaged (the paper's "same type averaged").
/// The solver keeps every hard cell bit-exactly at its resolved value.
#include <terracl/heightfield.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace terracl {

/// Kinds of hard constraint, in increasing priority.
enum class ConstraintKind : uint8_t { None = 0, Raster = 1, Polygon = 2, Polyline = 3, Point = 4 };

/// Hard cells of a width x height grid with their elevations (metres). Coordinates are in
/// pixels: x = column, y = row, cell centres on integers (cell (0, 0) covers [-0.5, 0.5)^2).
class ConstraintSet {
 public:
  ConstraintSet() = default;
  ConstraintSet(int width, int height);
  /// A band of a width x height grid: only rows [row0, row0 + rows) are stored (7 bytes per cell
  /// of the band), coordinates stay the whole grid's, constraints on other rows are checked and
  /// dropped (hypre's band reader: every MPI rank rasterises only its rows). Heightfields given
  /// to add_rasters / add_border / add_polygon_freeze / add_constraints_json then hold these rows.
  static ConstraintSet band(int width, int height, int row0, int rows);

  int width() const { return m_width; }
  int height() const { return m_height; }
  int row0() const { return m_row0; }
  int rows() const { return m_rows; }
  bool in_band(int y) const { return y >= m_row0 && y < m_row0 + m_rows; }
  /// Elevations of cells outside the band where a constraint file omits z (the band's rows come
  /// from `current`); unset: such a file is refused on a band.
  std::function<double(int x, int y)> outside_current;
  /// Number of hard cells.
  size_t count() const;
  bool empty() const { return count() == 0; }
  bool is_hard(int x, int y) const { return m_kind[index(x, y)] != 0; }
  /// Resolved elevation of a hard cell (NaN for a free cell).
  float value(int x, int y) const;
  /// All resolved values, row-major, NaN for free cells (what the solver uploads).
  std::vector<float> values() const;
  /// The hard cells only, in row-major order: flat indices (of the whole grid) and resolved values (the solver
  /// uploads these instead of the dense NaN raster: ~1 % of the bytes for sparse constraints).
  void hard_cells(std::vector<uint32_t>& index, std::vector<float>& value) const;

  /// One cell; higher-priority kinds replace, equal kinds average. Throws for NaN/Inf z or a
  /// cell outside the grid (`where` names the source in the message).
  void add_cell(int x, int y, double z, ConstraintKind kind, const std::string& where = "constraint");
  /// The cell nearest to (x, y).
  void add_point(double x, double y, double z, const std::string& where = "point");
  /// Vertices (x, y, z); z interpolated linearly by arc length; every cell whose centre lies
  /// within width/2 (at least 0.5) of the curve takes the z of the nearest point of the curve.
  void add_polyline(const std::vector<std::array<double, 3>>& pts, double width, const std::string& where = "polyline");
  /// Cells whose centre is inside the polygon (even-odd rule) take z.
  void add_polygon(const std::vector<std::array<double, 2>>& pts, double z, const std::string& where = "polygon");
  /// Cells inside the polygon keep their elevation in `current` ("freeze").
  void add_polygon_freeze(const std::vector<std::array<double, 2>>& pts, const Heightfield& current,
                          const std::string& where = "polygon");
  /// Every cell where `mask` is non-zero (and finite) takes the value of `elevation`.
  void add_rasters(const Heightfield& mask, const Heightfield& elevation, const std::string& where = "fixed-mask");
  /// Every cell fixed to the value of `h` (all-cells constraint, e.g. for tests and Dirichlet borders).
  void add_border(const Heightfield& h, const std::string& where = "border");

 private:
  size_t index(int x, int y) const { return size_t(y - m_row0) * size_t(m_width) + size_t(x); }
  void check_band_field(const Heightfield& h, const char* what, const std::string& where) const;
  std::vector<std::size_t> polygon_cells(const std::vector<std::array<double, 2>>& pts, const std::string& where) const;
  int m_width = 0, m_height = 0, m_row0 = 0, m_rows = 0;
  std::vector<uint8_t> m_kind;
  std::vector<float> m_sum;
  std::vector<uint16_t> m_count;
};

/// Adds the constraints of a JSON document (see docs/reconstruct.md):
///   {"units": "pixels" | "map",
///    "points":    [{"x": 10, "y": 20, "z": 1500}, ...],
///    "polylines": [{"points": [[x, y, z], ...], "width": 3}, ...],
///    "polygons":  [{"points": [[x, y], ...], "z": 1200}, {"points": [...], "z": "freeze"}]}
/// "map" (alias "georeferenced") coordinates go through the inverse geotransform of `georef`.
/// Points may also be [x, y, z] arrays. `current` provides the elevations of "freeze" polygons,
/// and of an omitted z: points and polyline vertices ([x, y]) then take the current elevation at
/// their nearest cell and polygons without z are frozen (null `current`: all of these are errors).
/// Every error names the JSON path ("<source>/polylines/2/points/1: ...").
void add_constraints_json(ConstraintSet& c, const nlohmann::json& doc, const Georef& georef, const Heightfield* current,
                          const std::string& source);

/// Reads a constraint JSON file and adds it (errors name the file and the JSON path).
void add_constraints_file(ConstraintSet& c, const std::string& path, const Georef& georef, const Heightfield* current);

}  // namespace terracl
