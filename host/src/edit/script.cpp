// Edit scripts: parsing (all operations validated before any runs) and the editing session.
#include "edit/state.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>

namespace terracl {

std::optional<Heightfield> parse_flat_spec(const std::string& spec) {
  if (spec.rfind("flat:", 0) != 0) return std::nullopt;
  static const std::regex re(R"(flat:(\d+)x(\d+)(?:@([0-9]*\.?[0-9]+(?:[eE][-+]?\d+)?))?)");
  std::smatch m;
  if (!std::regex_match(spec, m, re))
    throw UsageError("edit", fmt::format("'{}': expected flat:WIDTHxHEIGHT or flat:WIDTHxHEIGHT@CELLSIZE (metres)", abbreviate(spec)));
  // strtod/strtoll, not stol/stod: an overlong number is out of range, not "internal: stol".
  const long long w = std::strtoll(m[1].str().c_str(), nullptr, 10), h = std::strtoll(m[2].str().c_str(), nullptr, 10);
  const double cell = m[3].matched ? std::strtod(m[3].str().c_str(), nullptr) : 1.0;
  if (w < 2 || h < 2 || w > 65536 || h > 65536 || !(cell > 0) || !std::isfinite(cell))
    throw UsageError("edit", fmt::format("'{}': size must be 2..65536 per side and the cell size > 0", abbreviate(spec)));
  // Before allocating the base (terracl/memory.hpp): 20000^2 exhausted memory half-way.
  require_memory("edit", fmt::format("a {} x {} edit", w, h), double(w) * double(h) * edit_host_bytes_per_cell, 0, 0,
                 nullptr, "use a smaller base (flat:WxH, or crop the DEM)");
  Heightfield f(int(w), int(h), 0.f);
  f.georef.cell_x = f.georef.cell_y = cell;
  f.georef.geotransform = {0, cell, 0, 0, 0, -cell};
  return f;
}

nlohmann::json read_edit_script(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail("edit", "cannot open script '{}'", path);
  return read_json_file(path, "edit");  // depth and size limits (terracl/json_limits.hpp)
}

namespace {

using edit::Grid;
using edit::Operation;
using edit::Params;
using edit::param_error;

struct Parsed {
  std::vector<std::pair<std::string, Operation>> ops;
  double unit = 1, unit_y = 1;
};

Parsed parse_script(const json& script, Grid grid) {
  const json* ops = &script;
  std::string base = "";
  unsigned seed = 1;
  Parsed out;
  if (script.is_object()) {
    for (auto it = script.begin(); it != script.end(); ++it)
      if (it.key() != "operations" && it.key() != "units" && it.key() != "seed" && it.key() != "description" &&
          it.key() != "base")
        param_error("/" + it.key(), "unknown key (expected operations, units, seed, base, description)");
    if (!script.contains("operations")) param_error("/operations", "missing (required): the array of operations");
    ops = &script.at("operations");
    base = "/operations";
    if (script.contains("units")) {
      const json& u = script.at("units");
      if (u == "cells") out.unit = grid.cell_x, out.unit_y = grid.cell_y;
      else if (u != "m") param_error("/units", fmt::format("expected \"m\" or \"cells\", got {}", u.dump()));
    }
    if (script.contains("seed")) {
      if (!script.at("seed").is_number_integer() || script.at("seed").get<long long>() < 0)
        param_error("/seed", "expected a non-negative integer");
      seed = unsigned(script.at("seed").get<long long>());
    }
  }
  if (!ops->is_array()) param_error(base.empty() ? "/" : base, "expected an array of operations");
  grid.unit = out.unit;
  grid.unit_y = out.unit_y;
  for (size_t i = 0; i < ops->size(); ++i) {
    const std::string path = base + "/" + std::to_string(i);
    const json& j = (*ops)[i];
    if (!j.is_object()) param_error(path, fmt::format("expected an operation object {{\"op\": ...}}, got {}", j.dump()));
    if (!j.contains("op") || !j.at("op").is_string()) param_error(path + "/op", "missing: the operation name (a string)");
    const std::string name = j.at("op").get<std::string>();
    const edit::OpSpec* spec = nullptr;
    for (const auto& s : edit::operations())
      if (s.name == name) spec = &s;
    if (!spec) {
      std::string list;
      for (const auto& s : edit::operations()) list += (list.empty() ? "" : ", ") + s.name;
      param_error(path + "/op", fmt::format("unknown operation '{}' (known: {})", name, list));
    }
    grid.seed = seed * 1000003u + unsigned(i);
    Params p(j, path, grid);
    p.string("op");
    p.string("comment", "");
    Operation op = spec->parse(p);
    p.done();
    out.ops.emplace_back(name, std::move(op));
  }
  return out;
}

}  // namespace

EditSession::EditSession(Device& d, const Heightfield& base, EditOptions o) : m_options(std::move(o)) {
  require_finite(base, "edit", "the base terrain (fill nodata first: terracl fill_nodata)");
  GradientField g = extract_gradient(d, base);
  SolverOptions so = m_options.solver;
  so.initial = nullptr;
  so.progress = nullptr;
  m_state = std::make_unique<edit::EditState>(d, g, base, so);
}

EditSession::~EditSession() = default;

void validate_edit_script(const nlohmann::json& script, int width, int height, double cell, const std::string& base_dir) {
  Grid g;
  g.width = width;
  g.height = height;
  g.cell_x = g.cell_y = cell;
  g.base_dir = base_dir;
  parse_script(script, g);
}

void EditSession::validate(const nlohmann::json& script) const {
  Grid g = m_state->grid();
  g.base_dir = m_options.base_dir;
  parse_script(script, g);
}

void EditSession::apply(const nlohmann::json& script) {
  Grid g = m_state->grid();
  g.base_dir = m_options.base_dir;
  const Parsed parsed = parse_script(script, g);
  const size_t first = m_state->log().size();
  for (size_t i = 0; i < parsed.ops.size(); ++i) {
    report_progress(m_options.progress, "edit", double(i) / double(parsed.ops.size() + 1), parsed.ops[i].first);
    m_state->log().push_back({{"index", first + i}, {"op", parsed.ops[i].first}});
    const auto t0 = std::chrono::steady_clock::now();
    parsed.ops[i].second(*m_state);
    m_state->device().queue().finish();
    m_state->log().back()["ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  report_progress(m_options.progress, "edit", double(parsed.ops.size()) / double(parsed.ops.size() + 1), "reconstruct");
}

const Heightfield& EditSession::height() { return m_state->height(); }
const ReconstructResult& EditSession::solve(bool warm) {
  m_state->solve(warm);
  return m_state->last_solve();
}
GradientField EditSession::gradient() { return m_state->download(); }
size_t EditSession::hard_cells() const { return m_state->hard_count(); }
const nlohmann::json& EditSession::log() const { return m_state->log(); }

nlohmann::json EditSession::report() const {
  nlohmann::json r = {{"operations", m_state->log()}, {"hard_cells", m_state->hard_count()}, {"solves", m_state->solves()}};
  if (m_state->solves() > 0) {
    r["last_solve"] = m_state->last_solve().to_json();
    r["last_solve"]["width"] = m_state->grid().width;
    r["last_solve"]["height"] = m_state->grid().height;
  }
  return r;
}

std::vector<std::pair<std::string, std::string>> edit_operations() {
  std::vector<std::pair<std::string, std::string>> v;
  for (const auto& s : edit::operations()) v.emplace_back(s.name, s.summary);
  return v;
}

}  // namespace terracl
