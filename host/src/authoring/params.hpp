// SPDX-License-Identifier: Apache-2.0
#pragma once
// Typed access to one edit operation's JSON object. Every error names the JSON path
// ("/operations/3/radius: expected ...") and unknown keys are errors (typos must not pass silently).
#include <terracl/edit.hpp>
#include <terracl/stage.hpp>
#include <terracl/tensor.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace terracl::edit {

/// What parsing one operation learnt beyond its Operation: its support (the points it read and the
/// largest radius-like length, for the edited region and the falloff) and warnings. Shared by the
/// operation's Params and their children (tensor primitives, fit features).
struct ParseTrace {
  std::vector<std::string> warnings;
  /// Bounding box (metres, grid frame) of every point read; empty when no point was read.
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  /// Largest reach (radius, disc_radius, falloff, half width, pasted box...) in metres.
  double reach = 0;
  bool has_points() const { return x0 <= x1; }
};

/// The grid an edit script works on (coordinates are metres from cell (0, 0), x east, y south).
struct Grid {
  int width = 0, height = 0;
  double cell_x = 1, cell_y = 1;
  /// Metres per unit of plain-number horizontal lengths and x coordinates ("units": "m" or "cells");
  /// unit_y for y coordinates (cells may not be square).
  double unit = 1, unit_y = 1;
  /// Default noise seed of the operation being parsed (the script's seed + its index).
  unsigned seed = 1;
  /// Folder of the script file: relative file names are tried there when not found as given.
  std::string base_dir;
  /// Folders files named by operations must lie in (EditOptions::file_roots; empty: anywhere).
  std::vector<std::string> file_roots;
  /// The base's GDAL geotransform (corner convention) when it has one ("units": "map").
  bool georeferenced = false;
  std::array<double, 6> geotransform{0, 1, 0, 0, 0, -1};
  /// "units": "map": x, y coordinates are CRS coordinates (through the inverse geotransform).
  bool map = false;
  /// Where the operation being parsed records its support and warnings (may be null).
  ParseTrace* trace = nullptr;

  /// A script coordinate pair (script units) -> metres in the grid frame.
  Vec2 to_grid(double x, double y) const;
};

using terracl::resolve_path;

class Params;
/// The existing file named by parameter `key`, tried as given and then in the script's folder,
/// and inside the grid's file_roots when it has some; errors name the parameter.
std::string operation_file(Params& p, const std::string& key);

/// A vertex with an optional elevation (NaN when the point has only x, y).
struct Vec3 {
  double x = 0, y = 0, z = std::numeric_limits<double>::quiet_NaN();
};

[[noreturn]] void param_error(const std::string& path, const std::string& msg);

class Params {
 public:
  Params(const json& j, std::string path, const Grid& grid);

  const std::string& path() const { return m_path; }
  std::string where(const std::string& key) const { return m_path + "/" + key; }
  const Grid& grid() const { return m_grid; }
  bool has(const std::string& key) const;
  const json& raw(const std::string& key);
  Params child(const std::string& key);

  /// Horizontal length in metres: a number in the script's units, or a string with a unit ("2 km").
  double hlength(const std::string& key, std::optional<double> def = {}, double min = 0, bool strict_min = false);
  /// Vertical quantity in metres (a number, or "30 m", "0.2 km").
  double vlength(const std::string& key, std::optional<double> def = {});
  /// Plain number in [lo, hi].
  double number(const std::string& key, std::optional<double> def, double lo, double hi);
  int integer(const std::string& key, std::optional<int> def, int lo, int hi);
  bool boolean(const std::string& key, bool def);
  /// Angle in radians: a number of degrees, or a string with a unit ("0.5 rad").
  double angle(const std::string& key, std::optional<double> def_deg = {});
  std::string choice(const std::string& key, std::optional<std::string> def, const std::vector<std::string>& choices);
  std::string string(const std::string& key, std::optional<std::string> def = {});
  /// A point [x, y] in metres.
  Vec2 point(const std::string& key);
  /// Vertices [[x, y] or [x, y, z], ...] (x, y in metres, z in metres or NaN), at least `min` of them.
  std::vector<Vec3> points(const std::string& key, size_t min);
  std::vector<Vec3> points_of(const json& arr, const std::string& where, size_t min);

  /// Declares how far (metres) the operation acts beyond the points it read, when that is not one
  /// of its radius-like parameters (e.g. the half-diagonal of a pasted box).
  void note_reach(double metres);

  /// Throws when the object has keys that no accessor asked for, or when the points it read, grown
  /// by its reach, lie wholly outside the grid (the error names the points' JSON path).
  void done() const;

 private:
  const json& get(const std::string& key);
  json m_j;
  std::string m_path;
  void record_points(const std::vector<Vec3>& pts, const std::string& where);
  void record_reach(double metres);
  Grid m_grid;
  std::set<std::string> m_used;
  // This object's own points (for the off-grid check) and reach.
  double m_x0 = std::numeric_limits<double>::infinity(), m_y0 = m_x0, m_x1 = -m_x0, m_y1 = -m_x0;
  double m_reach = 0;
  std::string m_points_path;
};

}  // namespace terracl::edit
