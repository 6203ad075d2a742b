// SPDX-License-Identifier: Apache-2.0
#include "authoring/params.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

namespace terracl::edit {

void param_error(const std::string& path, const std::string& msg) { throw Error("edit", path + ": " + msg); }

namespace {
// convert_unit() reports as the pipeline; restate its message as the edit script's.
double unit_value(const json& v, const std::string& unit, const std::string& where) {
  try {
    return convert_unit(v, unit, where);
  } catch (const Error& e) {
    std::string m = e.what();
    const std::string pre = e.stage() + ": ";
    if (m.rfind(pre, 0) == 0) m = m.substr(pre.size());
    throw Error("edit", m);
  }
}
}  // namespace

Vec2 Grid::to_grid(double x, double y) const {
  if (!map) return {x * unit, y * unit_y};
  // CRS -> pixel through the inverse geotransform (corner convention, as constraint files do),
  // then cell centres on integers, then metres.
  const auto& gt = geotransform;
  const double det = gt[1] * gt[5] - gt[2] * gt[4];
  const double dx = x - gt[0], dy = y - gt[3];
  const double px = (gt[5] * dx - gt[2] * dy) / det - 0.5, py = (-gt[4] * dx + gt[1] * dy) / det - 0.5;
  return {px * cell_x, py * cell_y};
}

Params::Params(const json& j, std::string path, const Grid& grid) : m_j(j), m_path(std::move(path)), m_grid(grid) {
  if (!m_j.is_object()) param_error(m_path, fmt::format("expected a JSON object, got {}", m_j.dump()));
}

bool Params::has(const std::string& key) const { return m_j.contains(key) && !m_j.at(key).is_null(); }

const json& Params::get(const std::string& key) {
  m_used.insert(key);
  return m_j.at(key);
}

const json& Params::raw(const std::string& key) {
  if (!has(key)) param_error(where(key), "missing (required)");
  return get(key);
}

Params Params::child(const std::string& key) { return Params(raw(key), where(key), m_grid); }

double Params::hlength(const std::string& key, std::optional<double> def, double min, bool strict_min) {
  m_used.insert(key);
  double v;
  if (!has(key)) {
    if (!def) param_error(where(key), "missing (required): a horizontal length");
    v = *def;
  } else {
    const json& j = get(key);
    if (j.is_number()) v = j.get<double>() * m_grid.unit;
    else if (j.is_string()) v = unit_value(j, "m", where(key));
    else param_error(where(key), fmt::format("expected a length (a number or a string like \"2 km\"), got {}", j.dump()));
  }
  if (!std::isfinite(v) || (strict_min ? !(v > min) : !(v >= min)))
    param_error(where(key), fmt::format("expected a length {} {} m, got {} m", strict_min ? ">" : ">=", min, v));
  if (v > max_edit_length)  // 1e300 m overflowed the support and falloff arithmetic
    param_error(where(key), fmt::format("expected a length <= {:g} m, got {:g} m", max_edit_length, v));
  // An explicit width of 0 was accepted silently before (and drew nothing sensible): widths given
  // in a script must be positive; leaving the key out selects the default.
  if (key == "width" && has(key) && !(v > 0))
    param_error(where(key), fmt::format("expected a width > 0 m, got {} m (leave \"width\" out for the default)", v));
  if (key == "radius" || key == "disc_radius" || key == "falloff" || key == "fade" || key == "feather") record_reach(v);
  if (key == "width") record_reach(v / 2);
  const double cell = std::min(m_grid.cell_x, m_grid.cell_y);
  if ((key == "radius" || key == "disc_radius") && v < cell && m_grid.trace)
    m_grid.trace->warnings.push_back(fmt::format(
        "{}: {:g} m is less than one cell ({:g} m): the operation's support covers less than one cell and may "
        "have no visible effect",
        where(key), v, cell));
  return v;
}

void Params::record_reach(double metres) {
  m_reach = std::max(m_reach, metres);
  if (m_grid.trace) m_grid.trace->reach = std::max(m_grid.trace->reach, metres);
}

void Params::note_reach(double metres) { record_reach(metres); }

void Params::record_points(const std::vector<Vec3>& pts, const std::string& w) {
  for (const auto& v : pts) {
    m_x0 = std::min(m_x0, v.x), m_x1 = std::max(m_x1, v.x), m_y0 = std::min(m_y0, v.y), m_y1 = std::max(m_y1, v.y);
    if (m_grid.trace) {
      ParseTrace& t = *m_grid.trace;
      t.x0 = std::min(t.x0, v.x), t.x1 = std::max(t.x1, v.x), t.y0 = std::min(t.y0, v.y), t.y1 = std::max(t.y1, v.y);
    }
  }
  if (m_points_path.empty()) m_points_path = w;
}

double Params::vlength(const std::string& key, std::optional<double> def) {
  m_used.insert(key);
  if (!has(key)) {
    if (!def) param_error(where(key), "missing (required): a value in metres");
    return *def;
  }
  const json& j = get(key);
  if (!j.is_number() && !j.is_string()) param_error(where(key), fmt::format("expected metres, got {}", j.dump()));
  const double v = unit_value(j, "m", where(key));
  // Unbounded, a noise amplitude of 1e38 m gave +-8e37 m and 1e39 (Inf in float) did nothing.
  if (!std::isfinite(v) || std::fabs(v) > max_edit_vertical)
    param_error(where(key), fmt::format("expected metres within [{:g}, {:g}], got {:g} m", -max_edit_vertical,
                                        max_edit_vertical, v));
  return v;
}

double Params::number(const std::string& key, std::optional<double> def, double lo, double hi) {
  m_used.insert(key);
  double v;
  if (!has(key)) {
    if (!def) param_error(where(key), "missing (required): a number");
    v = *def;
  } else {
    const json& j = get(key);
    if (!j.is_number()) param_error(where(key), fmt::format("expected a number in [{}, {}], got {}", lo, hi, j.dump()));
    v = j.get<double>();
  }
  if (!(v >= lo && v <= hi)) param_error(where(key), fmt::format("expected a number in [{}, {}], got {}", lo, hi, v));
  return v;
}

int Params::integer(const std::string& key, std::optional<int> def, int lo, int hi) {
  m_used.insert(key);
  if (!has(key)) {
    if (!def) param_error(where(key), "missing (required): an integer");
    return *def;
  }
  const json& j = get(key);
  if (!j.is_number_integer() || j.get<long long>() < lo || j.get<long long>() > hi)
    param_error(where(key), fmt::format("expected an integer in [{}, {}], got {}", lo, hi, j.dump()));
  return j.get<int>();
}

bool Params::boolean(const std::string& key, bool def) {
  m_used.insert(key);
  if (!has(key)) return def;
  const json& j = get(key);
  if (!j.is_boolean()) param_error(where(key), fmt::format("expected true or false, got {}", j.dump()));
  return j.get<bool>();
}

double Params::angle(const std::string& key, std::optional<double> def_deg) {
  m_used.insert(key);
  if (!has(key)) {
    if (!def_deg) param_error(where(key), "missing (required): an angle in degrees");
    return *def_deg * M_PI / 180;
  }
  const json& j = get(key);
  if (j.is_number()) return j.get<double>() * M_PI / 180;
  if (j.is_string()) return unit_value(j, "rad", where(key));
  param_error(where(key), fmt::format("expected an angle in degrees, got {}", j.dump()));
}

std::string Params::choice(const std::string& key, std::optional<std::string> def, const std::vector<std::string>& choices) {
  const std::string v = string(key, def);
  for (const auto& c : choices)
    if (c == v) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
  param_error(where(key), fmt::format("'{}' is not one of: {}", v, list));
}

std::string Params::string(const std::string& key, std::optional<std::string> def) {
  m_used.insert(key);
  if (!has(key)) {
    if (!def) param_error(where(key), "missing (required): a string");
    return *def;
  }
  const json& j = get(key);
  if (!j.is_string()) param_error(where(key), fmt::format("expected a string, got {}", j.dump()));
  return j.get<std::string>();
}

Vec2 Params::point(const std::string& key) {
  const auto p = points_of(json::array({raw(key)}), where(key), 1);
  return {p[0].x, p[0].y};
}

std::vector<Vec3> Params::points(const std::string& key, size_t min) { return points_of(raw(key), where(key), min); }

std::vector<Vec3> Params::points_of(const json& arr, const std::string& w, size_t min) {
  if (!arr.is_array()) param_error(w, fmt::format("expected an array of [x, y] or [x, y, z] points, got {}", arr.dump()));
  if (arr.size() < min) param_error(w, fmt::format("expected at least {} point(s), got {}", min, arr.size()));
  std::vector<Vec3> out;
  for (size_t i = 0; i < arr.size(); ++i) {
    const json& p = arr[i];
    const std::string pw = w + "/" + std::to_string(i);
    if (!p.is_array() || p.size() < 2 || p.size() > 3)
      param_error(pw, fmt::format("expected [x, y] or [x, y, z], got {}", p.dump()));
    for (const auto& c : p)
      if (!c.is_number() || !std::isfinite(c.get<double>())) param_error(pw, fmt::format("coordinates must be numbers, got {}", p.dump()));
    const Vec2 q = m_grid.to_grid(p[0].get<double>(), p[1].get<double>());
    Vec3 v{q.x, q.y};
    if (p.size() == 3) v.z = p[2].get<double>();
    out.push_back(v);
  }
  record_points(out, w);
  // Arrays given as the whole point (e.g. "center": [x, y]) arrive wrapped by point().
  return out;
}

}  // namespace terracl::edit

namespace terracl {
std::string resolve_path(const std::string& path, const std::string& base_dir) {
  namespace fs = std::filesystem;
  if (path_exists(path) || base_dir.empty() || fs::path(path).is_absolute()) return path;
  const fs::path alt = fs::path(base_dir) / path;
  return path_exists(alt.string()) ? alt.string() : path;
}
}  // namespace terracl

namespace terracl::edit {

void Params::done() const {
  for (auto it = m_j.begin(); it != m_j.end(); ++it)
    if (!m_used.count(it.key())) param_error(where(it.key()), "unknown parameter");
  // A primitive 50 km off the map used to pass silently and change nothing (or, through the
  // solve, everything): the points grown by the reach must touch the grid's cells.
  if (m_x0 <= m_x1) {
    const Grid& g = m_grid;
    const double gx0 = -0.5 * g.cell_x, gx1 = (g.width - 0.5) * g.cell_x;
    const double gy0 = -0.5 * g.cell_y, gy1 = (g.height - 0.5) * g.cell_y;
    if (m_x1 + m_reach < gx0 || m_x0 - m_reach > gx1 || m_y1 + m_reach < gy0 || m_y0 - m_reach > gy1)
      param_error(m_points_path,
                  fmt::format("the primitive lies wholly outside the {}x{} grid: its points span x {:.6g}..{:.6g} m, y "
                              "{:.6g}..{:.6g} m from the centre of cell (0, 0){} with a reach of {:g} m, the grid covers "
                              "x {:g}..{:g} m, y {:g}..{:g} m{}",
                              g.width, g.height, m_x0, m_x1, m_y0, m_y1, "", m_reach, gx0, gx1, gy0, gy1,
                              g.map ? " (map coordinates converted through the base's geotransform)" : ""));
  }
}

}  // namespace terracl::edit

namespace terracl::edit {

namespace {
bool inside(const std::filesystem::path& file, const std::string& root) {
  std::error_code ec;
  const std::string r = std::filesystem::canonical(root, ec).string();
  if (ec) return false;
  const std::string f = file.string();
  if (f == r) return true;  // a root may be one file (the studio's base raster)
  return f.size() > r.size() && f.compare(0, r.size(), r) == 0 && (f[r.size()] == '/' || r == "/");
}
}  // namespace

std::string operation_file(Params& p, const std::string& key) {
  namespace fs = std::filesystem;
  const std::string given = p.string(key);
  const Grid& g = p.grid();
  if (g.file_roots.empty()) {
    const std::string path = resolve_path(given, g.base_dir);
    if (!path_exists(path)) param_error(p.where(key), fmt::format("file '{}' not found", given));
    return path;
  }
  // Confined (the studio): relative names are taken in the script's folder only, never the
  // server's working directory, and links are followed before the check so none leads out.
  const fs::path asked = fs::path(given).is_absolute() || g.base_dir.empty() ? fs::path(given) : fs::path(g.base_dir) / given;
  std::error_code ec;
  const fs::path real = fs::canonical(asked, ec);
  if (ec || !path_exists(real.string())) param_error(p.where(key), fmt::format("file '{}' not found in the workspace", given));
  for (const std::string& root : g.file_roots)
    if (inside(real, root)) return real.string();
  param_error(p.where(key), fmt::format("'{}' is outside the workspace: operations may only read files inside it "
                                        "(or a folder given with --allow-dir)", given));
}

}  // namespace terracl::edit
