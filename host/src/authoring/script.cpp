// SPDX-License-Identifier: Apache-2.0
// Edit scripts: parsing (all operations validated before any runs) and the editing session.
#include "authoring/state.hpp"
#include <terracl/launch.hpp>

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/gradient.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <set>

namespace terracl {

std::optional<Heightfield> parse_flat_spec(const std::string& spec) {
  if (spec.rfind("flat:", 0) != 0) return std::nullopt;
  static const std::regex re(R"(flat:(\d+)x(\d+)(?:@([0-9]*\.?[0-9]+(?:[eE][-+]?\d+)?))?(?:([+-][0-9]*\.?[0-9]+))?)");
  std::smatch m;
  if (!std::regex_match(spec, m, re))
    throw UsageError("edit", fmt::format("'{}': expected flat:WIDTHxHEIGHT, flat:WIDTHxHEIGHT@CELLSIZE or flat:WIDTHxHEIGHT@CELLSIZE+ELEVATION or -ELEVATION (metres)", abbreviate(spec)));
  // strtod/strtoll, not stol/stod: an overlong number is out of range, not "internal: stol".
  const long long w = std::strtoll(m[1].str().c_str(), nullptr, 10), h = std::strtoll(m[2].str().c_str(), nullptr, 10);
  const double cell = m[3].matched ? std::strtod(m[3].str().c_str(), nullptr) : 1.0;
  if (w < 2 || h < 2 || w > 65536 || h > 65536 || !(cell > 0) || !std::isfinite(cell))
    throw UsageError("edit", fmt::format("'{}': size must be 2..65536 per side and the cell size > 0", abbreviate(spec)));
  // Before allocating the base (terracl/memory.hpp): 20000^2 exhausted memory half-way.
  require_memory("edit", fmt::format("a {} x {} edit", w, h), double(w) * double(h) * edit_host_bytes_per_cell, 0, 0,
                 nullptr, "use a smaller base (flat:WxH, or crop the DEM)");
  // An elevation above 0 keeps carved valleys above sea level (renders draw water below 0 m).
  const double z = m[4].matched ? std::strtod(m[4].str().c_str(), nullptr) : 0.0;  // "+500", "-200"
  if (!std::isfinite(z) || std::abs(z) > 1e5)
    throw UsageError("edit", fmt::format("'{}': the elevation after the cell size must be within +-100000 m", abbreviate(spec)));
  Heightfield f{int(w), int(h), float(z)};
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
  std::vector<edit::ParseTrace> traces;  // one per operation
  std::vector<nlohmann::json> supports;  // one per operation: [x0, y0, x1, y1] cells, or "grid"
  std::vector<bool> changes_terrain;     // one per operation (OpSpec::changes_terrain)
  double unit = 1, unit_y = 1;
  std::optional<bool> local;             // "solve": "local" | "global"
  std::optional<double> falloff;         // "locality": {"falloff": ...}
};

// The cells an operation can touch, from what its parameters said (points grown by the reach).
nlohmann::json support_of(const std::string& name, const json& j, const edit::ParseTrace& t, const Grid& g) {
  const bool whole = name == "regularize" || (name == "fit" && (!j.contains("clear") || j.at("clear") != false));
  if (whole || !t.has_points()) return "grid";
  const int x0 = std::max(0, edit::cell_index(std::floor((t.x0 - t.reach) / g.cell_x))), x1 = std::min(g.width - 1, edit::cell_index(std::ceil((t.x1 + t.reach) / g.cell_x)));
  const int y0 = std::max(0, edit::cell_index(std::floor((t.y0 - t.reach) / g.cell_y))), y1 = std::min(g.height - 1, edit::cell_index(std::ceil((t.y1 + t.reach) / g.cell_y)));
  return nlohmann::json::array({x0, y0, x1, y1});
}

Parsed parse_script(const json& script, Grid grid) {
  const json* ops = &script;
  std::string base = "";
  unsigned seed = 1;
  Parsed out;
  if (script.is_object()) {
    for (auto it = script.begin(); it != script.end(); ++it)
      if (it.key() != "operations" && it.key() != "units" && it.key() != "seed" && it.key() != "description" &&
          it.key() != "base" && it.key() != "solve" && it.key() != "locality")
        param_error("/" + it.key(), "unknown key (expected operations, units, seed, base, description, solve, locality)");
    if (!script.contains("operations")) param_error("/operations", "missing (required): the array of operations");
    ops = &script.at("operations");
    base = "/operations";
    if (script.contains("units")) {
      const json& u = script.at("units");
      if (u == "cells") {
        out.unit = grid.cell_x, out.unit_y = grid.cell_y;
        grid.unit = out.unit, grid.unit_y = out.unit_y;  // for "locality" below
      } else if (u == "map") {
        if (!grid.georeferenced)
          param_error("/units", "\"map\" coordinates need a georeferenced base (a raster with a geotransform); this "
                                "base has none (use \"m\" or \"cells\")");
        const auto& gt = grid.geotransform;
        if (gt[1] * gt[5] - gt[2] * gt[4] == 0) param_error("/units", "the base's geotransform is not invertible");
        grid.map = true;
      } else if (u != "m") {
        param_error("/units", fmt::format("expected \"m\", \"cells\" or \"map\", got {}", u.dump()));
      }
    }
    if (script.contains("solve")) {
      const json& v = script.at("solve");
      if (v != "local" && v != "global") param_error("/solve", fmt::format("expected \"local\" or \"global\", got {}", v.dump()));
      out.local = v == "local";
    }
    if (script.contains("locality")) {
      if (out.local == false) param_error("/locality", "applies to local solves, and \"solve\" is \"global\"");
      Params lp(script.at("locality"), "/locality", grid);
      out.falloff = lp.hlength("falloff", {}, 0, true);
      lp.done();
      out.local = true;
    }
    if (script.contains("seed")) {
      if (!script.at("seed").is_number_integer() || script.at("seed").get<long long>() < 0)
        param_error("/seed", "expected a non-negative integer");
      seed = unsigned(script.at("seed").get<long long>());
    }
  }
  if (!ops->is_array()) param_error(base.empty() ? "/" : base, "expected an array of operations");
  // Counted before any operation is parsed: validating a million took 271 s and 964 MB.
  if (ops->size() > max_edit_operations)
    param_error(base.empty() ? "/" : base, fmt::format("{} operations; a script may hold at most {} operations (split it into "
                                                       "several scripts run one after the other)",
                                                       ops->size(), max_edit_operations));
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
    edit::ParseTrace trace;
    grid.trace = &trace;
    Params p(j, path, grid);
    p.string("op");
    p.string("comment", "");
    // "enabled": false keeps an operation in the script (validated, seeds unchanged) without
    // running it: the studio's hidden layers.
    const bool enabled = p.boolean("enabled", true);
    Operation op = spec->parse(p);
    p.done();
    grid.trace = nullptr;
    if (!enabled) continue;  // validated above; a hidden layer has no support and runs nothing
    out.supports.push_back(support_of(name, j, trace, grid));
    out.traces.push_back(std::move(trace));
    out.changes_terrain.push_back(spec->changes_terrain);
    out.ops.emplace_back(name, std::move(op));
  }
  return out;
}

}  // namespace

namespace {
// True when every enabled operation is a landform stroke placed relative to the ground (its change
// is computed whole and fades to nothing), a lake (no change at all) or a painted style (a change of
// the relief finer than 4 cells that keeps the block means, inside its region).
bool landform_strokes_only(const nlohmann::json& script) {
  static const std::set<std::string> always = {"mountain_range", "peak", "volcano", "canyon", "lake", "style"};
  static const std::set<std::string> when_relative = {"crest", "river", "cliff"};
  if (!script.is_object() || !script.contains("operations")) return true;
  for (const auto& op : script["operations"]) {
    if (!op.is_object() || !op.value("enabled", true)) continue;
    const std::string name = op.value("op", std::string());
    if (always.count(name)) continue;
    if (!when_relative.count(name) || op.contains("elevation")) return false;
    if (op.contains("points") && op["points"].is_array())
      for (const auto& v : op["points"])
        if (v.is_array() && v.size() >= 3) return false;
  }
  return true;
}
}  // namespace

EditSession::EditSession(Device& d, const Heightfield& base, EditOptions o) : m_options(std::move(o)), m_georef(base.georef) {
  require_finite(base, "edit", "the base terrain (fill nodata first: terracl fill_nodata)");
  GradientField g = extract_gradient(d, base);
  SolverOptions so = m_options.solver;
  so.initial = nullptr;
  so.progress = nullptr;
  m_state = std::make_unique<edit::EditState>(d, g, base, so);
  // Local solves by default on a real base. A flat base (every cell equal, e.g. flat:WxH) solves
  // locally too while the strokes are landforms whose change fades to nothing (the far field then
  // keeps its level exactly, and a stroke on a 1025^2 plain re-solves its window, not the map);
  // the first operation that needs the whole map (a fault's step, absolute constraints, noise,
  // tensors...) turns it global for the session, as flat bases always solved.
  bool flat = true;
  for (float v : base.z) flat = flat && v == base.z.front();
  m_auto_flat = flat && !m_options.locality;
  m_state->set_local(m_options.locality.value_or(true));
  m_state->set_landform_detail(m_options.landform_detail);
}

EditSession::EditSession(std::unique_ptr<edit::EditState> state, EditOptions o, Georef g, bool auto_flat)
    : m_state(std::move(state)), m_options(std::move(o)), m_georef(std::move(g)), m_auto_flat(auto_flat) {}

std::unique_ptr<EditSession> EditSession::snapshot() const {
  return std::unique_ptr<EditSession>(new EditSession(m_state->clone(), m_options, m_georef, m_auto_flat));
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

namespace {
Grid script_grid(const edit::EditState& s, const EditOptions& o, const Georef& geo) {
  Grid g = s.grid();
  g.base_dir = o.base_dir;
  g.file_roots = o.file_roots;
  g.georeferenced = geo.has_geotransform;
  g.geotransform = geo.geotransform;
  return g;
}
}  // namespace

void EditSession::validate(const nlohmann::json& script) const { check(script); }

std::vector<std::string> EditSession::check(const nlohmann::json& script) const {
  const Parsed parsed = parse_script(script, script_grid(*m_state, m_options, m_georef));
  std::vector<std::string> w;
  for (const auto& t : parsed.traces) w.insert(w.end(), t.warnings.begin(), t.warnings.end());
  return w;
}

std::vector<std::string> EditSession::warnings() const {
  std::vector<std::string> w;
  for (const auto& e : m_state->log())
    if (e.contains("warnings"))
      for (const auto& s : e["warnings"]) w.push_back(s.get<std::string>());
  return w;
}

bool EditSession::local() const { return m_state->local(); }
nlohmann::json EditSession::locality() const { return m_state->locality_report(); }

void EditSession::apply(const nlohmann::json& script) {
  const Parsed parsed = parse_script(script, script_grid(*m_state, m_options, m_georef));
  if (parsed.local) m_state->set_local(*parsed.local), m_auto_flat = false;
  if (m_auto_flat && !landform_strokes_only(script)) m_state->set_local(false), m_auto_flat = false;
  if (parsed.falloff) m_state->set_falloff(parsed.falloff);
  const size_t first = m_state->log().size();
  // The operations' launches are queued without a wait between them (on a GPU a clFinish per
  // operation cost more than its kernels); one finish after the last. An operation's "ms" is then
  // the host time it took to queue its work (plus any read-back it does itself); TERRACL_PHASES=1
  // waits after each one so that its "ms" includes its device time.
  const bool per_op_wait = std::getenv("TERRACL_PHASES") || std::getenv("TERRACL_MG_PROFILE");
  for (size_t i = 0; i < parsed.ops.size(); ++i) {
    // Ctrl-C in the CLI, a cancel or a time budget in the studio (terracl/interrupt.hpp).
    if (stop_requested()) throw Cancelled("edit", fmt::format("stopped before operation {} ({})", first + i, parsed.ops[i].first));
    report_progress(m_options.progress, "edit", double(i) / double(parsed.ops.size() + 1), parsed.ops[i].first);
    m_state->log().push_back({{"index", first + i}, {"op", parsed.ops[i].first}, {"support", parsed.supports[i]}});
    if (!parsed.traces[i].warnings.empty()) m_state->log().back()["warnings"] = parsed.traces[i].warnings;
    // Each operation's reach and support are noted just before it runs, not all up front: an
    // operation that reconstructs mid-script (erode, drainage, amplify read the terrain) then
    // solves with the supports of the operations before it only, so the state after operation k
    // of a replay is the state after replaying operations 0..k (the studio's snapshots rely on it).
    // A layer over the terrain (a lake) changes no cell: noting its support would only force a
    // re-solve, and a lake's reach is its whole basin, not its seed.
    if (parsed.changes_terrain[i]) {
      m_state->note_reach(parsed.traces[i].reach);
      edit::EditState::Support sp{0, 0, m_state->grid().width - 1, m_state->grid().height - 1, parsed.traces[i].reach};
      if (parsed.supports[i].is_array())
        sp.x0 = parsed.supports[i][0], sp.y0 = parsed.supports[i][1], sp.x1 = parsed.supports[i][2], sp.y1 = parsed.supports[i][3];
      m_state->note_support(sp);
    }
    const auto t0 = std::chrono::steady_clock::now();
    parsed.ops[i].second(*m_state);
    if (per_op_wait) m_state->device().queue().finish();
    m_state->log().back()["ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  m_state->device().queue().finish();  // errors of queued work surface here, inside apply()
  report_progress(m_options.progress, "edit", double(parsed.ops.size()) / double(parsed.ops.size() + 1), "reconstruct");
}

const Heightfield& EditSession::height() { return m_state->height(); }
void EditSession::rebase() { m_state->rebase(); }
const ReconstructResult& EditSession::solve(bool warm) {
  m_state->solve(warm);
  return m_state->last_solve();
}
GradientField EditSession::gradient() { return m_state->download(); }
size_t EditSession::hard_cells() const { return m_state->hard_count(); }
const std::vector<float>& EditSession::hard_constraints() const { return m_state->hard(); }
const nlohmann::json& EditSession::log() const { return m_state->log(); }

nlohmann::json EditSession::report() const {
  // Lakes are filled on the final terrain (a solve when stale) before anything is read, so their
  // figures, the log's and the solve's agree with height() and water().
  const Heightfield* water = m_state->water();
  nlohmann::json r = {{"operations", m_state->log()}, {"hard_cells", m_state->hard_count()}, {"solves", m_state->solves()},
                      {"solve", m_state->local() ? "local" : "global"}, {"warnings", warnings()}};
  r["launch"] = describe_launch(m_state->device());  // the device's launch shape and group sizes
  if (m_state->local() && m_state->locality_report().contains("falloff_m"))
    r["falloff_m"] = m_state->locality_report()["falloff_m"];  // the largest used by the last solve
  if (m_state->solves() > 0) r["locality"] = m_state->locality_report();
  if (water) {
    size_t cells = 0;
    double volume = 0, deepest = 0;
    for (float d : water->z)
      if (d > 0) ++cells, volume += d, deepest = std::max(deepest, double(d));
    r["lakes"] = m_state->lakes_report();
    r["water"] = {{"cells", cells},
                  {"volume_m3", volume * m_state->grid().cell_x * m_state->grid().cell_y},
                  {"max_depth_m", deepest}};
  }
  if (m_state->solves() > 0) {
    r["last_solve"] = m_state->last_solve().to_json();
    r["last_solve"]["width"] = m_state->grid().width;
    r["last_solve"]["height"] = m_state->grid().height;
  }
  return r;
}

std::optional<Heightfield> EditSession::erosion_change() const {
  const std::vector<float>& c = m_state->erosion_change();
  if (c.empty()) return std::nullopt;
  Heightfield out(m_state->grid().width, m_state->grid().height);
  out.z = c;
  out.georef = m_georef;
  return out;
}

std::optional<Heightfield> EditSession::water() {
  const Heightfield* w = m_state->water();
  if (!w) return std::nullopt;
  Heightfield out = *w;
  out.georef = m_georef;  // the base's, as the terrain is written with
  return out;
}

nlohmann::json EditSession::lakes() {
  return m_state->has_lakes() ? m_state->lakes_report() : nlohmann::json::array();
}

std::vector<std::pair<std::string, std::string>> edit_operations() {
  std::vector<std::pair<std::string, std::string>> v;
  for (const auto& s : edit::operations()) v.emplace_back(s.name, s.summary);
  return v;
}

}  // namespace terracl
