#include "edit/params.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

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
  return v;
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
  if (!std::isfinite(v)) param_error(where(key), "expected a finite value");
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
    Vec3 v{p[0].get<double>() * m_grid.unit, p[1].get<double>() * m_grid.unit_y};
    if (p.size() == 3) v.z = p[2].get<double>();
    out.push_back(v);
  }
  // Arrays given as the whole point (e.g. "center": [x, y]) arrive wrapped by point().
  return out;
}

}  // namespace terracl::edit

namespace terracl {
std::string resolve_path(const std::string& path, const std::string& base_dir) {
  namespace fs = std::filesystem;
  if (fs::exists(path) || base_dir.empty() || fs::path(path).is_absolute()) return path;
  const fs::path alt = fs::path(base_dir) / path;
  return fs::exists(alt) ? alt.string() : path;
}
}  // namespace terracl

namespace terracl::edit {

void Params::done() const {
  for (auto it = m_j.begin(); it != m_j.end(); ++it)
    if (!m_used.count(it.key())) param_error(where(it.key()), "unknown parameter");
}

}  // namespace terracl::edit
