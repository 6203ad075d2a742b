// SPDX-License-Identifier: Apache-2.0
// The studio session: operation list, undo/redo, warm incremental edits and replays, workspace
// files, live erosion.
#include "studio/session.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/io.hpp>
#include <terracl/mesh.hpp>
#include <terracl/warm_up.hpp>

#include "authoring/landform_detail.hpp"

#include "authoring/ops_erode.hpp"

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace fs = std::filesystem;

namespace terracl::studio {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Undo history is bounded so a long session cannot grow without limit.
constexpr size_t kMaxUndo = 200;
// A script may hold at most as many operations as `terracl edit` takes.
constexpr size_t kMaxOps = max_edit_operations;

}  // namespace

Session::Session(Device& d, const std::string& base, const std::string& workspace,
                 const std::vector<std::string>& allowed_dirs,
                 std::function<void(const std::function<bool()>&)> compile_ahead)
    : m_device(d), m_base_spec(base), m_compile_ahead(std::move(compile_ahead)) {
  fs::create_directories(workspace);
  m_workspace = fs::canonical(workspace).string();
  m_file_roots = {m_workspace};
  for (const std::string& dir : allowed_dirs) {
    std::error_code ec;
    const fs::path real = fs::canonical(dir, ec);
    if (ec || !fs::is_directory(real)) throw UsageError("studio", fmt::format("--allow-dir '{}': not a folder", dir));
    m_file_roots.push_back(real.string());
  }
  if (auto flat = parse_flat_spec(base)) {
    m_base = std::move(*flat);
  } else {
    if (!path_exists(base)) throw UsageError("studio", fmt::format("base terrain '{}' not found", base));
    m_base_spec = fs::absolute(base).string();  // the saved script replays from anywhere
    m_file_roots.push_back(fs::canonical(base).string());  // the page amplifies with the base's texture
    m_base = read_heightfield(base);
    m_nodata = nodata_cells(m_base);
    if (!m_nodata.empty()) fill_nodata_harmonic(m_base);  // as `terracl edit` does
  }
  m_header = {{"units", "m"}, {"seed", 1}};
  replay(m_ops);
  m_last = {{"mode", "start"}};
  start_warm_up();
}

Session::~Session() {
  m_warm_stop = true;
  if (m_warm.joinable()) m_warm.join();
}

namespace {
long long now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
constexpr long long kWarmIdleNs = 1'500'000'000;  // quiet time before the warm-up builds on
}  // namespace

Session::Busy::Busy(Session& s) : s(s) { ++s.m_busy; }
Session::Busy::~Busy() {
  s.m_quiet_since_ns = now_ns();
  --s.m_busy;
}

void Session::start_warm_up() {
  if (const char* v = std::getenv("TERRACL_STUDIO_WARMUP"); v && std::string(v) == "0") return;
  // The programs in the order a first stroke needs them: the solver and the field, the stroke
  // kernels, erosion as the erode operation and the live erosion build it on this grid (default
  // parameters, with and without channel diffusion), then every other embedded kernel file.
  std::vector<std::pair<std::string, std::string>> programs;
  auto add = [&](const std::string& file, const std::string& options) {
    for (const auto& p : programs)
      if (p.first == file && p.second == options) return;
    programs.emplace_back(file, options);
  };
  for (const char* f : {"multigrid", "multigrid_coarse", "gradient", "tensor", "noise", "raster"}) add(f, "");
  try {
    edit::Grid g;
    g.width = m_base.width;
    g.height = m_base.height;
    g.cell_x = m_base.georef.cell_x;
    g.cell_y = m_base.georef.cell_y;
    const json op = {{"op", "erode"}, {"steps", 1}};
    edit::Params p(op, "/warm_up", g);
    p.string("op");
    ErosionParams e = edit::parse_erode_spec(p).params;
    add("erosion", erosion_program_options(m_device, m_base.width, e, true));
    e.channel_diffusion = e.channel_diffusion > 0 ? 0.0 : 0.5;
    add("erosion", erosion_program_options(m_device, m_base.width, e, true));
  } catch (const std::exception&) {
    // the defaults always parse; erosion then compiles on first use
  }
  for (const std::string& f : kernel_files()) add(f, "");
  m_warming = true;
  m_warm = std::thread([this, programs] {
#ifdef __linux__
    // The lowest CPU priority for this thread only (PoCL compiles in the calling thread): a
    // request arriving meanwhile gets the cores.
    setpriority(PRIO_PROCESS, pid_t(syscall(SYS_gettid)), 19);
#endif
    const auto t0 = std::chrono::steady_clock::now();
    // Before each program: wait until no request has run on the device for kWarmIdleNs.
    const auto stop = [this] {
      while (!m_warm_stop && (m_busy > 0 || now_ns() - m_quiet_since_ns < kWarmIdleNs))
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      return m_warm_stop.load();
    };
    const size_t ready = warm_up(m_device, programs, stop);
    if (!m_warm_stop) {
      fmt::print("studio: {} OpenCL programs ready ({:.1f} s, compiled or loaded from the cache)\n", ready,
                 ms_since(t0) / 1000.0);
      std::fflush(stdout);
    }
    // PoCL compiles each kernel again for each work-group shape at its first launch: done ahead
    // too (in other processes, whose compiles land in the shared disk cache), at this priority.
    if (m_compile_ahead && !stop()) {
      const auto t2 = std::chrono::steady_clock::now();
      try {
        m_compile_ahead([this] { return m_warm_stop.load(); });
        if (!m_warm_stop) {
          fmt::print("studio: kernels compiled ahead ({:.1f} s)\n", ms_since(t2) / 1000.0);
          std::fflush(stdout);
        }
      } catch (const std::exception& e) {
        fmt::print(stderr, "studio: compiling ahead: {}\n", e.what());
      }
    }
    // The landform tools' detail dictionaries (docs/authoring.md, "Detail and styles"): the base's
    // own texture on a real DEM, and the bundled styles the tools fall back to.
    const auto t1 = std::chrono::steady_clock::now();
    const auto [lo, hi] = std::minmax_element(m_base.z.begin(), m_base.z.end());
    std::vector<std::string> styles = edit::bundled_styles();
    if (lo != m_base.z.end() && *hi - *lo > 1.0f) styles.insert(styles.begin(), "local");
    size_t learned = 0;
    for (const auto& st : styles) {
      if (stop()) break;
      try {
        learned += edit::warm_style(st, st == "local" ? &m_base : nullptr, stop);
      } catch (const std::exception& e) {
        fmt::print(stderr, "studio: style {}: {}\n", st, e.what());
      }
    }
    if (!m_warm_stop) {
      fmt::print("studio: {} detail dictionaries ready ({:.1f} s)\n", learned, ms_since(t1) / 1000.0);
      std::fflush(stdout);
    }
    m_warming = false;
  });
}

json Session::full_script(const json& ops) const {
  json s = m_header;
  s["base"] = m_base_spec;
  s["operations"] = ops;
  return s;
}

json Session::script() const { return full_script(m_ops); }

json Session::state() const {
  return {{"version", m_version},
          {"width", m_base.width},
          {"height", m_base.height},
          {"cell_x", m_base.georef.cell_x},
          {"cell_y", m_base.georef.cell_y},
          {"base", m_base_spec},
          {"units", m_header.value("units", "m")},
          {"operations", m_ops},
          {"can_undo", !m_undo.empty()},
          {"can_redo", !m_redo.empty()},
          {"eroding", bool(m_erosion)},
          // Compiling the OpenCL programs ahead in the background (start_warm_up).
          {"warming", m_warming.load()},
          {"erosion_steps", m_erosion_steps},
          {"last", m_last},
          // Each lake's figures on the live terrain (cached until the next solve), so the page
          // knows when to fetch the water layer and can show an empty lake's warning.
          {"lakes", m_edit->lakes()}};
}

json Session::appended_only(const json& ops) const {
  // The operations already applied become disabled placeholders, so the new ones keep their script
  // index (their default noise seeds depend on it) and nothing runs, or is parsed (copy_paste reads
  // its file when parsed), twice.
  json tail = ops;
  for (size_t i = 0; i < m_ops.size(); ++i) tail[i] = {{"op", "regularize"}, {"enabled", false}};
  return tail;
}

void Session::apply_ops(const json& tail) {
  m_edit->apply(full_script(tail));
  m_edit->height();
}

// A replay keeps a snapshot after each expensive operation, so that changing a layer after one
// replays from there. Hidden ones run nothing.
bool expensive_operation(const json& op) {
  static const std::set<std::string> names = {"erode", "drainage", "amplify", "strata", "fit"};
  if (!op.is_object() || (op.contains("enabled") && op["enabled"] == false)) return false;
  return op.contains("op") && op["op"].is_string() && names.count(op["op"].get<std::string>());
}

namespace {
// At most this many snapshots (least recently used go first): each holds a deep copy of the edit
// state, about 48 bytes a cell (60 once noise ran), 50 MB at 1025^2.
constexpr size_t kMaxSnapshots = 4;

// ops[0, end) with ops[0, start) as disabled placeholders (see Session::appended_only).
json chunk(const json& ops, size_t start, size_t end) {
  json c = json::array();
  for (size_t i = 0; i < end; ++i) c.push_back(i < start ? json{{"op", "regularize"}, {"enabled", false}} : ops[i]);
  return c;
}
}  // namespace

std::string Session::prefix_key(const json& ops, size_t end) const {
  json prefix = json::array();
  for (size_t i = 0; i < end && i < ops.size(); ++i) prefix.push_back(ops[i]);
  return full_script(prefix).dump();
}

void Session::keep_snapshot(const json& ops, size_t end, const EditSession& e) {
  std::string key = prefix_key(ops, end);
  for (Snapshot& sn : m_snapshots)
    if (sn.key == key) {
      sn.used = ++m_snapshot_clock;
      return;
    }
  if (m_snapshots.size() >= kMaxSnapshots)
    m_snapshots.erase(std::min_element(m_snapshots.begin(), m_snapshots.end(),
                                       [](const Snapshot& a, const Snapshot& b) { return a.used < b.used; }));
  m_snapshots.push_back({std::move(key), end, e.snapshot(), ++m_snapshot_clock});
}

size_t Session::replay(const json& ops) {
  // The latest snapshot whose operations (and header) are this script's first ones.
  Snapshot* best = nullptr;
  for (Snapshot& sn : m_snapshots)
    if (sn.end <= ops.size() && (!best || sn.end > best->end) && sn.key == prefix_key(ops, sn.end)) best = &sn;
  std::unique_ptr<EditSession> e;
  size_t from = 0;
  if (best) {
    e = best->edit->snapshot();  // the kept one stays as it is, for the next change
    from = best->end;
    best->used = ++m_snapshot_clock;
  } else {
    EditOptions o;
    o.base_dir = m_workspace;
    o.file_roots = m_file_roots;
    e = std::make_unique<EditSession>(m_device, m_base, o);
  }
  // The script in chunks that end after each expensive operation, each applied with the operations
  // before it as placeholders (indices and default seeds unchanged). With each operation's support
  // noted when it runs (EditSession::apply), the state after a chunk is the state a replay of the
  // whole script has at that point, so the snapshot taken there (before any extra solve: a solve
  // would change the next warm start) continues bit for bit as `terracl edit` would.
  size_t start = from;
  bool ran = false;
  for (size_t i = from; i < ops.size(); ++i) {
    if (!expensive_operation(ops[i])) continue;
    e->apply(full_script(chunk(ops, start, i + 1)));
    ran = true;
    start = i + 1;
    keep_snapshot(ops, start, *e);
  }
  if (start < ops.size() || (!ran && !best)) e->apply(full_script(chunk(ops, start, ops.size())));
  e->height();
  if (from > 0 && std::getenv("TERRACL_STUDIO_VERIFY_SNAPSHOTS")) {
    // Debugging aid: the full replay from the base must give the same bits.
    EditOptions o;
    o.base_dir = m_workspace;
    o.file_roots = m_file_roots;
    auto full = std::make_unique<EditSession>(m_device, m_base, o);
    full->apply(full_script(ops));
    const bool same = full->height().z == e->height().z;
    fmt::print(stderr, "studio: replay from snapshot at operation {} {} the full replay\n", from,
               same ? "matches" : "DIFFERS FROM");
    if (!same) e = std::move(full), from = 0;
  }
  m_edit = std::move(e);
  m_canonical = true;
  return from;
}

void Session::commit(const json& ops, bool record_undo) {
  const Busy busy(*this);
  if (!ops.is_array()) throw RequestError(400, "/operations: expected an array of operations");
  if (ops.size() > kMaxOps) throw RequestError(413, fmt::format("/operations: at most {} operations", kMaxOps));
  const auto t0 = std::chrono::steady_clock::now();
  bool append = ops.size() > m_ops.size();
  for (size_t i = 0; append && i < m_ops.size(); ++i) append = ops[i] == m_ops[i];
  // An appended expensive operation (an erosion, also the live erosion's commit) replays from the
  // latest snapshot instead: the replay keeps a snapshot after it, so changing a later layer then
  // starts there, and the terrain is canonical (the warm append is not: its warm starts differ).
  for (size_t i = m_ops.size(); append && i < ops.size(); ++i)
    if (expensive_operation(ops[i])) append = false;
  const json tail = append ? appended_only(ops) : json();
  // Throws with the JSON path (nothing changed yet); warnings (a support under one cell) are shown.
  const std::vector<std::string> warnings = m_edit->check(full_script(append ? tail : ops));
  erosion_cancel();
  std::string mode;
  size_t from = 0;
  // Where a change's time goes (state's last.phases_ms; scripts/bench-studio-browser.py prints it).
  json phases = {{"check", ms_since(t0)}};
  try {
    auto t = std::chrono::steady_clock::now();
    if (append) {
      apply_ops(tail);
      m_canonical = false;
      mode = "append";
      from = m_ops.size();
    } else {
      from = replay(ops);
      mode = "replay";
    }
    phases["run"] = ms_since(t);
    t = std::chrono::steady_clock::now();
    // A validated script can still solve to non-finite elevations (extreme parameters): refuse it.
    for (float z : m_edit->height().z)
      if (!std::isfinite(z)) throw RequestError(400, "/operations: these operations give non-finite elevations");
    phases["finite"] = ms_since(t);
    t = std::chrono::steady_clock::now();
    // The live terrain becomes the base of the next append's local solve, which then re-solves
    // only its own stroke's window instead of every edit since the session's base (the export
    // replays the script canonically, docs/studio.md "Latency").
    if (append && m_edit->local()) m_edit->rebase();
    phases["rebase"] = ms_since(t);
  } catch (...) {
    // Validated operations can still fail while running (a file vanished, a cancel, the time
    // budget): go back to the previous list so the session stays consistent. That replay rebuilds
    // an accepted state, so a pending stop must not cut it short.
    NoStopScope finish_rollback;
    replay(m_ops);
    throw;
  }
  if (record_undo) {
    m_undo.push_back(m_ops);
    if (m_undo.size() > kMaxUndo) m_undo.erase(m_undo.begin());
    m_redo.clear();
  }
  m_ops = ops;
  ++m_version;
  // from: the first operation that ran (a replay from a snapshot starts after its expensive layer).
  m_last = {{"mode", mode}, {"from", from}, {"ms", ms_since(t0)}, {"operations", m_ops.size()},
            {"snapshots", m_snapshots.size()}, {"warnings", warnings}, {"phases_ms", phases}};
  // An append solved locally moved only the cells of its window: the page fetches just those.
  if (append && m_edit->local()) {
    const json loc = m_edit->locality();
    for (const char* k : {"prepare_ms", "solve_ms"})
      if (loc.contains(k)) m_last["phases_ms"][std::string("local_") + k] = loc[k];
    m_last["window"] = loc.value("solved_cells", 0) > 0 && loc.contains("window") ? loc["window"] : json::array();
  }
}

namespace {
size_t check_index(const json& ops, size_t i, const char* what, bool allow_end = false) {
  if (i > ops.size() || (!allow_end && i == ops.size()))
    throw RequestError(404, fmt::format("{}: no operation {} (the script has {})", what, i, ops.size()));
  return i;
}
void check_op(const json& op) {
  if (!op.is_object()) throw RequestError(400, "/op: expected an operation object {\"op\": ...}");
}
}  // namespace

void Session::add(const json& op, std::optional<size_t> index) {
  check_op(op);
  json ops = m_ops;
  const size_t at = index ? check_index(ops, *index, "index", true) : ops.size();
  ops.insert(ops.begin() + long(at), op);
  commit(ops);
}

void Session::update(size_t index, const json& op) {
  check_op(op);
  json ops = m_ops;
  ops[check_index(ops, index, "index")] = op;
  commit(ops);
}

void Session::remove(size_t index) {
  json ops = m_ops;
  ops.erase(ops.begin() + long(check_index(ops, index, "index")));
  commit(ops);
}

void Session::move(size_t from, size_t to) {
  json ops = m_ops;
  check_index(ops, from, "from");
  check_index(ops, to, "to");
  json op = ops[from];
  ops.erase(ops.begin() + long(from));
  ops.insert(ops.begin() + long(to), op);
  commit(ops);
}

void Session::set_visible(size_t index, bool visible) {
  json ops = m_ops;
  json& op = ops[check_index(ops, index, "index")];
  if (visible)
    op.erase("enabled");
  else
    op["enabled"] = false;
  commit(ops);
}

void Session::undo() {
  if (m_undo.empty()) throw RequestError(409, "nothing to undo");
  json prev = m_undo.back();
  json cur = m_ops;
  commit(prev, false);
  m_undo.pop_back();
  m_redo.push_back(cur);
}

void Session::redo() {
  if (m_redo.empty()) throw RequestError(409, "nothing to redo");
  json next = m_redo.back();
  json cur = m_ops;
  commit(next, false);
  m_redo.pop_back();
  m_undo.push_back(cur);
}

void Session::load_script(const json& script) {
  json ops;
  json header = {{"units", "m"}, {"seed", 1}};
  if (script.is_array()) {
    ops = script;
  } else if (script.is_object()) {
    if (!script.contains("operations"))
      throw RequestError(400, "/operations: missing (required): the array of operations");
    ops = script["operations"];
    for (const char* k : {"units", "seed", "description"})
      if (script.contains(k)) header[k] = script[k];
  } else {
    throw RequestError(400, "/: expected an edit script (an object with operations, or an array)");
  }
  const json old_header = m_header;
  m_header = header;
  try {
    commit(ops);
  } catch (...) {
    m_header = old_header;
    throw;
  }
}

std::string Session::resolve(const std::string& rel, bool must_exist) const {
  if (rel.empty()) throw RequestError(400, "/path: expected a file name inside the workspace");
  if (rel.size() > 1024 || rel.find('\0') != std::string::npos) throw RequestError(400, "/path: invalid file name");
  const fs::path p(rel);
  if (p.is_absolute())
    throw RequestError(403, fmt::format("/path: '{}' is absolute: only names inside the workspace", rel));
  std::error_code ec;  // a component longer than the file system allows, a loop of links
  const fs::path full = fs::weakly_canonical(fs::path(m_workspace) / p, ec);
  if (ec) throw RequestError(400, fmt::format("/path: '{}' is not a usable file name ({})", rel, ec.message()));
  // A link whose target is missing would be replaced by the written file (or lead out later).
  if (fs::is_symlink(fs::symlink_status(full, ec)))
    throw RequestError(403, fmt::format("/path: '{}' is a link to a missing file: not written through", rel));
  const std::string f = full.string();
  if (f.size() <= m_workspace.size() || f.compare(0, m_workspace.size(), m_workspace) != 0 ||
      f[m_workspace.size()] != '/')
    throw RequestError(403, fmt::format("/path: '{}' is outside the workspace", rel));
  if (must_exist && !path_exists(full.string(), true))
    throw RequestError(404, fmt::format("/path: '{}' not found in the workspace", rel));
  return f;
}

void Session::save(const std::string& rel) {
  const std::string path = resolve(rel, false);
  if (fs::path(path).extension() != ".json") throw RequestError(400, "/path: a script is saved as .json");
  fs::create_directories(fs::path(path).parent_path());
  write_text_file_atomic(path, script().dump(2) + "\n");
}

void Session::load(const std::string& rel) {
  const std::string path = resolve(rel, true);
  json s;
  try {
    s = read_edit_script(path);
  } catch (const Error& e) {
    throw RequestError(400, e.what());
  }
  load_script(s);
}

std::string Session::export_to(const std::string& rel) {
  const std::string path = resolve(rel, false);
  const std::string ext = fs::path(path).extension().string();
  if (ext != ".tif" && ext != ".tiff" && ext != ".exr" && ext != ".png" && ext != ".r16" && ext != ".glb")
    throw RequestError(400, fmt::format("/path: '{}': export as .tif, .exr, .png, .r16 or .glb", rel));
  fs::create_directories(fs::path(path).parent_path());
  Heightfield h = canonical();
  h.georef = m_base.georef;
  h.metadata = m_base.metadata;
  h.metadata["terracl:edit_script"] = script().dump();
  if (ext != ".glb") restore_nodata(h, m_nodata);  // as `terracl edit` writes it (a mesh needs every cell)
  if (ext == ".glb")
    mesh::write_mesh(mesh::triangulate_simplified(h, 0.5), path, h.metadata);
  else
    write_heightfield(h, path);
  return path;
}

const Heightfield& Session::terrain() {
  const Busy busy(*this);
  return m_edit->height();
}

const Heightfield& Session::canonical() {
  const Busy busy(*this);
  if (!m_canonical) replay(m_ops);
  return m_edit->height();
}

// ---- live erosion ----

void Session::erosion_start(const json& params) {
  const Busy busy(*this);
  if (!params.is_object()) throw RequestError(400, "/: expected erosion parameters {\"rain\": ..., ...}");
  json op = params;
  op["op"] = "erode";
  op["steps"] = 1;  // the number of steps is known at commit
  json ops = m_ops;
  ops.push_back(op);
  m_edit->validate(full_script(ops));
  edit::Grid g;
  g.width = m_base.width;
  g.height = m_base.height;
  g.cell_x = m_base.georef.cell_x;
  g.cell_y = m_base.georef.cell_y;
  if (m_header.value("units", "m") == "cells") g.unit = g.cell_x, g.unit_y = g.cell_y;
  edit::Params p(op, "/operations/" + std::to_string(m_ops.size()), g);
  p.string("op");
  const edit::ErodeSpec spec = edit::parse_erode_spec(p);
  const Heightfield& h = m_edit->height();
  const std::vector<float> w = edit::erode_weight(spec, g, m_edit->hard_constraints());
  m_erosion = std::make_unique<Erosion>(m_device, h, spec.params, &w);
  m_erosion_weight = w;
  m_erosion_settle = spec.params.settle;
  m_settled.reset(), m_settled_raw.reset();
  m_erosion_op = op;
  m_erosion_steps = 0;
}

Heightfield Session::erosion_step(int steps) {
  const Busy busy(*this);
  if (!m_erosion) throw RequestError(409, "no erosion running (POST /api/erosion/start first)");
  if (steps < 1 || steps > 1000) throw RequestError(400, "/steps: expected an integer in [1, 1000]");
  m_erosion->run(steps);
  m_erosion_steps += steps;
  // What the committed "erode" operation will give: the bed with the suspended sediment settled.
  if (!m_erosion_settle) return m_erosion->bed();
  // Routing the load costs ~0.3 s per million cells: on grids larger than kFullSettleCells it runs
  // every kSettlePeriodMs, and the frames between show that settled bed plus the raw bed's change
  // since, so the view stays live; the commit replays the operation, which routes exactly.
  constexpr size_t kFullSettleCells = 100000;
  constexpr double kSettlePeriodMs = 400;
  Heightfield raw = m_erosion->bed();
  if (raw.z.size() <= kFullSettleCells || !m_settled || ms_since(m_settled_at) > kSettlePeriodMs) {
    m_settled = m_erosion->settled_bed(&m_erosion_weight);
    m_settled_raw = std::move(raw);
    m_settled_at = std::chrono::steady_clock::now();
    return *m_settled;
  }
  Heightfield out = *m_settled;
  for (size_t i = 0; i < out.z.size(); ++i) out.z[i] += raw.z[i] - m_settled_raw->z[i];
  return out;
}

void Session::erosion_commit() {
  if (!m_erosion) throw RequestError(409, "no erosion running");
  if (m_erosion_steps == 0) throw RequestError(409, "no erosion step run yet");
  json op = m_erosion_op;
  op["steps"] = m_erosion_steps;
  json ops = m_ops;
  ops.push_back(op);
  commit(ops);  // records the operation; cancels the preview
}

void Session::erosion_cancel() {
  m_erosion.reset();
  m_erosion_steps = 0;
}

}  // namespace terracl::studio
