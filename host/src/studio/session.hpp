// SPDX-License-Identifier: Apache-2.0
#pragma once
// The studio's one shared session (docs/studio.md): the operation list IS an edit script (the JSON
// of `terracl edit`), replayed on an EditSession that re-solves warm on the device. Every method
// validates its input before changing anything, so a rejected request leaves the session as it was.
// Not thread-safe by itself: the server serialises requests with one mutex.
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <terracl/device.hpp>
#include <terracl/edit.hpp>
#include <terracl/erosion.hpp>
#include <terracl/heightfield.hpp>
#include <vector>

namespace terracl::studio {

using json = nlohmann::json;

/// Thrown for bad requests (HTTP 400 unless `status` says otherwise); message names the field.
struct RequestError : std::runtime_error {
  RequestError(int status, const std::string& msg) : std::runtime_error(msg), status(status) {}
  int status;
};

/// Operations that cost far more than a stroke (they reconstruct the terrain mid-script, simulate
/// on it, or rasterise many curves): replays keep a snapshot after them, previews leave them out.
bool expensive_operation(const json& op);

/// The sampling step k that keeps every k-th of `side` cells, at most `max_side` of them.
int sample_step(int side, int max_side);
/// The sampling step of `h`'s longer side (as /api/terrain.f32 and the previews sample).
int preview_step(const Heightfield& h, int max_side);

class Session {
 public:
  /// `base`: a raster path or flat:WxH[@cell]; `workspace`: the only folder scripts and exports
  /// may be read from or written to; operations may also read files in `allowed_dirs`.
  /// `compile_ahead`: StudioOptions::compile_ahead, run by the background warm-up.
  Session(Device& d, const std::string& base, const std::string& workspace,
          const std::vector<std::string>& allowed_dirs = {},
          std::function<void(const std::function<bool()>&)> compile_ahead = {});
  ~Session();

  /// {version, width, height, cell_x, cell_y, operations, can_undo, can_redo, last, lakes}
  json state() const;
  /// The script as `terracl edit` reads it (base, units, seed, operations).
  json script() const;

  void add(const json& op, std::optional<size_t> index);
  void update(size_t index, const json& op);
  void remove(size_t index);
  void move(size_t from, size_t to);
  void set_visible(size_t index, bool visible);
  void undo();
  void redo();
  /// Replaces the operation list (and units/seed) with `script`'s (its "base" is ignored: the
  /// session keeps its own base).
  void load_script(const json& script);

  /// Workspace-relative file names; anything outside the workspace is refused (403).
  void save(const std::string& rel);
  void load(const std::string& rel);
  /// .tif .exr .png .r16 .glb, of the canonical terrain (the script replayed from the base, as
  /// `terracl edit` computes it).
  std::string export_to(const std::string& rel);
  /// The Export dialog (export.cpp): {name, format: tif|png16|exr|r16|glb, preset?, masks?: [flow,
  /// slope, wear, deposition, water]} -> {written: [paths], size, masks: {name: {max, unit}}}.
  json export_set(const json& request);
  std::string resolve(const std::string& rel, bool must_exist) const;

  /// The live terrain (warm-solved after each edit).
  const Heightfield& terrain();
  /// The terrain `terracl edit` computes for script(): replays from the base when the live one
  /// was reached incrementally.
  const Heightfield& canonical();
  const Heightfield& base() const { return m_base; }
  /// Water depth of the script's lakes on the live terrain (docs/authoring.md "Lakes"); nullopt
  /// without a lake operation.
  std::optional<Heightfield> water() { return m_edit->water(); }

  // ---- live erosion (docs/studio.md): a preview that becomes an "erode" operation on commit ----
  void erosion_start(const json& params);
  /// Runs `steps` steps; returns the current bed.
  Heightfield erosion_step(int steps);
  void erosion_commit();
  void erosion_cancel();
  bool eroding() const { return bool(m_erosion); }

  long long version() const { return m_version; }

  // ---- feedback while drawing (preview.cpp) ----
  /// The terrain with `op` appended (or replacing operation `*replace`), solved on a grid of every
  /// k-th cell (at most `max_side` a side); nothing is recorded. Operations after a replaced one
  /// that are too slow for a drag (erode, drainage, amplify, ...) are left out.
  Heightfield preview(const json& op, std::optional<size_t> replace, int max_side);
  double preview_ms() const { return m_preview_ms; }

 private:
  json full_script(const json& ops) const;
  /// Validates `ops`, then makes them current: incremental (apply the new tail warm) when the
  /// current list is a prefix of `ops`, else a replay from the base. Pushes the undo state.
  void commit(const json& ops, bool record_undo = true);
  json appended_only(const json& ops) const;
  void apply_ops(const json& tail);
  /// Rebuilds m_edit for `ops` as `terracl edit` computes it: from the latest snapshot whose
  /// prefix equals ops' (else from the base), keeping a snapshot after every expensive operation
  /// it runs. Returns the index of the first operation it ran.
  size_t replay(const json& ops);

  // ---- snapshots (docs/studio.md, "Snapshots") ----
  /// The EditSession right after operations [0, end) ran (a deep copy taken before any extra
  /// solve, so it continues exactly as a replay of the whole script would), valid while those
  /// operations and the script's header are unchanged (`key`: the JSON of that prefix script).
  struct Snapshot {
    std::string key;
    size_t end = 0;
    std::unique_ptr<EditSession> edit;
    unsigned long long used = 0;  ///< for least-recently-used eviction
  };
  std::string prefix_key(const json& ops, size_t end) const;
  void keep_snapshot(const json& ops, size_t end, const EditSession& e);
  std::vector<Snapshot> m_snapshots;
  unsigned long long m_snapshot_clock = 0;

  Device& m_device;
  std::string m_base_spec, m_workspace;
  std::vector<std::string> m_file_roots;  ///< where operations may read files (workspace + allowed)
  Heightfield m_base;
  std::vector<size_t> m_nodata;  ///< the base's nodata cells (filled for editing, nodata in exports)
  json m_header;  ///< units, seed, description of the script (everything but operations and base)
  json m_ops = json::array();
  std::vector<json> m_undo, m_redo;
  std::unique_ptr<EditSession> m_edit;
  bool m_canonical = true;  ///< m_edit was built by a replay (no incremental step since)
  long long m_version = 0;
  json m_last;  ///< mode and timings of the last change

  std::optional<Heightfield> m_preview_ground;  ///< the coarse terrain a dragged stroke is drawn on
  json m_preview_key;
  double m_preview_ms = 0;

  // ---- compiling ahead (docs/studio.md, "First strokes"): every OpenCL program the studio can
  // use is built (or loaded from the cache) in the background at start; only the program cache is
  // touched (under its own lock), so requests run meanwhile.
  void start_warm_up();
  std::thread m_warm;
  std::function<void(const std::function<bool()>&)> m_compile_ahead;  // StudioOptions::compile_ahead
  std::atomic<bool> m_warming{false}, m_warm_stop{false};
  /// Device work of requests (commit, preview, terrain, erosion) marks the session busy; the
  /// warm-up starts its next program only after kWarmIdle of quiet (PoCL compiles one program at a
  /// time, so a build in the background would hold up the request's own).
  std::atomic<int> m_busy{0};
  std::atomic<long long> m_quiet_since_ns{0};
  struct Busy {
    Session& s;
    explicit Busy(Session& s);
    ~Busy();
  };

  std::unique_ptr<Erosion> m_erosion;
  json m_erosion_op;
  int m_erosion_steps = 0;
  std::vector<float> m_erosion_weight;  // the brush weight, for the settled preview
  bool m_erosion_settle = true;
  // The live view's settled bed (the load in transit routed downstream, as the committed erode
  // gives it) and the raw bed it was computed from; on a large grid the routing is recomputed
  // every kSettlePeriodMs, and frames between add the raw bed's change since (docs/studio.md).
  std::optional<Heightfield> m_settled, m_settled_raw;
  std::chrono::steady_clock::time_point m_settled_at;
};

}  // namespace terracl::studio
