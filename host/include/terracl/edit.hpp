// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Gradient-domain authoring with JSON edit scripts (docs/authoring.md).
///
/// A script is {"units": "m" | "cells" | "map", "seed": 1, "solve": "local" | "global",
/// "locality": {"falloff": 2000}, "operations": [{"op": "crest", ...}, ...]} (or just
/// the array of operations). Operations edit the gradient field (tensors, noise, landform curves,
/// copy-paste) and add hard elevation constraints (crest, cliff, river, mesa, freeze, fit); the
/// terrain is the multigrid reconstruction of the edited field under the constraints. Coordinates
/// are metres from the centre of cell (0, 0), x east (columns), y south (rows); angles are degrees
/// counter-clockwise from east on a north-up map. Bad operations or parameters throw
/// terracl::Error("edit", "<JSON path>: <what was expected>") before anything runs.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>
#include <terracl/reconstruct.hpp>

#include <nlohmann/json.hpp>

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace terracl {

namespace edit {
class EditState;
}

/// Limits of an edit script (the CLI and the studio share them). Operations: each is validated and
/// replayed on every run, and a million took minutes and a gigabyte just to validate.
constexpr size_t max_edit_operations = 1000;
/// Largest magnitude, in metres, of a vertical quantity (elevation, height, depth, amplitude): ten
/// times the relief of the Earth, and far below where float32 elevations lose all precision.
constexpr double max_edit_vertical = 1e5;
/// Largest horizontal length (radius, width, falloff...), in metres: more than twice the Earth's
/// circumference.
constexpr double max_edit_length = 1e8;

/// Settings of an EditSession (`terracl edit`).
struct EditOptions {
  SolverOptions solver;   ///< initial/progress are managed by the session
  Progress progress;
  std::string base_dir;   ///< folder for relative file names in the script (copy_paste, fit)
  /// When not empty, files named by operations (copy_paste source, amplify exemplar/dictionary,
  /// fit file) must be one of these files or lie inside one of these folders once links are
  /// resolved; other names are refused. The studio confines them to its workspace, its base raster
  /// and its --allow-dir folders.
  std::vector<std::string> file_roots;
  /// Local solves (docs/authoring.md, "Locality"): true = local, false = global, nullopt = local
  /// unless the base is flat (every cell equal, e.g. flat:WxH). A script's "solve" overrides it.
  std::optional<bool> locality;
  /// Landform strokes draw sparse-dictionary detail (docs/authoring.md, "Detail and styles"); the
  /// studio's coarse previews turn it off (their grid is a sample of the terrain).
  bool landform_detail = true;
};

/// "flat:WIDTHxHEIGHT[@CELLSIZE][+ELEVATION]" -> a level heightfield (cell size in metres, default 1; elevation in metres, default 0); nullopt
/// when `spec` does not start with "flat:"; throws on a malformed spec.
std::optional<Heightfield> parse_flat_spec(const std::string& spec);

/// Checks every operation of `script` against a width x height grid of `cell` metres without a
/// device (what EditSession::validate does); throws the same errors. Used by the fuzz harness.
void validate_edit_script(const nlohmann::json& script, int width, int height, double cell,
                          const std::string& base_dir = "");

/// `path` when it exists, else `base_dir`/`path` when that exists, else `path`.
std::string resolve_path(const std::string& path, const std::string& base_dir);

/// Reads a script file; malformed JSON is an error naming the file, line and column.
nlohmann::json read_edit_script(const std::string& path);

/// An interactive editing session: a base terrain, operations applied in order, and the
/// reconstruction warm-started from the previous solution.
class EditSession {
 public:
  EditSession(Device& d, const Heightfield& base, EditOptions o = {});
  ~EditSession();
  EditSession(const EditSession&) = delete;
  EditSession& operator=(const EditSession&) = delete;

  /// The current terrain (solved when stale) becomes the base of later local solves, which then
  /// re-solve only the windows of the operations applied after it. The studio rebases after each
  /// append (docs/studio.md, "Latency"); a replay of the whole script does not, so its terrain can
  /// differ from the rebased one within the solver's tolerance.
  void rebase();
  /// A deep copy (docs/studio.md, "Snapshots"): the copy continues exactly as this session would,
  /// so applying the same operations to both gives bit-identical terrains. Copies the field and
  /// scratch buffers on the device (20 bytes a cell, 32 once noise ran) and the host state
  /// (about 28 bytes a cell). Take it right after apply(), before height(), when the copy must
  /// continue as a replay of the whole script would (height() re-solves, and solves warm-start
  /// from the last solution).
  std::unique_ptr<EditSession> snapshot() const;

  /// Validates every operation of `script` (throwing with JSON paths), then runs them.
  void apply(const nlohmann::json& script);
  /// Validates without running.
  void validate(const nlohmann::json& script) const;
  /// Validates without running and returns the script's warnings (e.g. an operation whose
  /// support covers less than one cell), each starting with its JSON path.
  std::vector<std::string> check(const nlohmann::json& script) const;
  /// Warnings of every operation applied so far (also in log() and report()).
  std::vector<std::string> warnings() const;
  /// Whether solves are local (only the cells within the falloff of the edits move).
  bool local() const;
  /// What the last local solve did (docs/authoring.md, "Locality"): mode, falloff_m, changed_cells,
  /// solved_cells and window [x0, y0, width, height] (the cells it may have moved; every other cell
  /// kept its elevation bit for bit); an empty object before the first local solve.
  nlohmann::json locality() const;
  /// The current terrain (reconstructs when an operation changed anything).
  const Heightfield& height();
  /// Reconstructs now (warm: from the previous solution, else from scratch), returning the
  /// solver's figures.
  const ReconstructResult& solve(bool warm = true);
  GradientField gradient();
  size_t hard_cells() const;
  /// Hard elevation constraints, row-major, NaN for free cells.
  const std::vector<float>& hard_constraints() const;
  /// Per-operation log: op, index, milliseconds and operation-specific figures.
  const nlohmann::json& log() const;
  /// Log plus the last solve's figures; with lake operations also "lakes" (as lakes()) and
  /// "water" (cells, volume_m3, max_depth_m of the combined layer), which reconstructs when stale.
  nlohmann::json report() const;
  /// Water depth in metres (>= 0, 0 on dry cells) of the script's `lake` operations, filled on the
  /// current terrain (reconstructs when stale; docs/authoring.md "Lakes"), where lakes overlap the
  /// highest water surface; nullopt when no lake operation ran. The terrain is not changed.
  std::optional<Heightfield> water();
  /// Per-lake figures on the current terrain, one per lake operation in script order: index,
  /// rule, seed_cell, level_m, cells, area_m2, volume_m3, max_depth_m (spill: spill_cell,
  /// spills_off_map), warnings (an empty lake); an empty array without lakes.
  nlohmann::json lakes();
  /// The elevation change (m) the script's `erode` operations made, each against the terrain it
  /// eroded, summed: negative where they wore the ground down, positive where they deposited;
  /// nullopt when no erode operation ran. Later operations' changes are not in it.
  std::optional<Heightfield> erosion_change() const;

 private:
  EditSession(std::unique_ptr<edit::EditState> state, EditOptions o, Georef g, bool auto_flat);
  std::unique_ptr<edit::EditState> m_state;
  EditOptions m_options;
  Georef m_georef;  ///< of the base ("units": "map")
  /// A flat base with no locality chosen solves locally while every operation is a landform
  /// stroke (changes that fade to nothing) and globally from the first one that is not.
  bool m_auto_flat = false;
};

/// Name and one-line summary of every edit operation.
std::vector<std::pair<std::string, std::string>> edit_operations();

/// Gradient image (paper section 3): a two-channel PNG with (r, g) = 2^(p-1) (1 + g/m), clamped to
/// [0, 2^p - 1], p = 16 bits, m = the largest |component| (stored in the sidecar "<file>.json" with
/// the cell size). Decoding error is at most m / 2^(p-1) per component.
void write_gradient_image(const GradientField& g, const std::string& path);
/// Reads a gradient image written by write_gradient_image (the sidecar gives m and the cell size).
GradientField read_gradient_image(const std::string& path);

}  // namespace terracl
