// SPDX-License-Identifier: Apache-2.0
// The studio's feedback while drawing (docs/studio.md, "Feedback while drawing"): a coarse-level
// solve of the stroke being drawn or dragged, on a grid of at most `max_side` cells a side. Nothing
// is recorded; the release then posts the operation and the full-resolution terrain replaces it.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "studio/session.hpp"

namespace terracl::studio {
namespace {

// Operations too slow to rerun for every frame of a drag (and copy_paste, which reads its file
// each time): when they follow the changed one they are left out of the preview (the release
// replays them).
bool slow_for_a_drag(const json& op) {
  return expensive_operation(op) || (op.is_object() && op.value("op", std::string()) == "copy_paste");
}

// Every `step`-th cell of `h` (the cells the coarse grid's centres fall on, so script coordinates
// in metres from the centre of cell (0, 0) mean the same place on both grids).
Heightfield sample(const Heightfield& h, int step) {
  Heightfield c((h.width - 1) / step + 1, (h.height - 1) / step + 1);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) c.at(x, y) = h.at(x * step, y * step);
  c.georef = h.georef;
  c.georef.cell_x *= step;
  c.georef.cell_y *= step;
  c.georef.geotransform[1] *= step, c.georef.geotransform[2] *= step;
  c.georef.geotransform[4] *= step, c.georef.geotransform[5] *= step;
  return c;
}

}  // namespace

int sample_step(int side, int max_side) {
  // the smallest k with (side - 1) / k + 1 <= max_side
  return std::max(1, (side + max_side - 3) / std::max(1, max_side - 1));
}

int preview_step(const Heightfield& h, int max_side) { return sample_step(std::max(h.width, h.height), max_side); }

Heightfield Session::preview(const json& op, std::optional<size_t> replace, int max_side) {
  const Busy busy(*this);
  const auto t0 = std::chrono::steady_clock::now();
  if (!op.is_object()) throw RequestError(400, "/op: expected an operation object {\"op\": ...}");
  if (m_header.value("units", "m") != "m")
    throw RequestError(400, "/op: previews need a script in metres (\"units\": \"m\")");
  if (replace && *replace >= m_ops.size())
    throw RequestError(404, fmt::format("/index: no operation {} (the script has {})", *replace, m_ops.size()));
  const size_t at = replace.value_or(m_ops.size());
  const int step = preview_step(m_base, max_side);

  // The terrain the stroke is drawn on, at the coarse level: the live terrain when the stroke comes
  // last (a new stroke), else the operations before it replayed on the coarse grid (kept for the
  // whole drag: the key is those operations and the grid).
  const json prefix(m_ops.begin(), m_ops.begin() + long(at));
  const json key = {{"ops", prefix}, {"step", step}, {"version", at == m_ops.size() ? m_version : -1}};
  if (!m_preview_ground || m_preview_key != key) {
    if (at == m_ops.size()) {
      m_preview_ground = sample(m_edit->height(), step);
    } else {
      EditOptions o;
      o.base_dir = m_workspace;
      o.file_roots = m_file_roots;
      o.landform_detail = false;
      EditSession coarse(m_device, sample(m_base, step), o);
      coarse.apply(full_script(prefix));
      m_preview_ground = coarse.height();
    }
    m_preview_key = key;
  }

  // The stroke (and the cheap operations after it) on that ground; the indices of the operations
  // before it are kept with disabled placeholders, so default noise seeds are the script's.
  json ops = json::array();
  for (size_t i = 0; i < at; ++i) ops.push_back({{"op", "regularize"}, {"enabled", false}});
  ops.push_back(op);
  for (size_t i = at + (replace ? 1 : 0); i < m_ops.size(); ++i) {
    json later = m_ops[i];
    if (slow_for_a_drag(later)) later["enabled"] = false;
    ops.push_back(later);
  }
  EditOptions o;
  o.base_dir = m_workspace;
  o.file_roots = m_file_roots;
  o.locality = m_edit->local();
  o.landform_detail = false;
  EditSession s(m_device, *m_preview_ground, o);
  s.apply(full_script(ops));  // bad parameters throw with their JSON path (400)
  Heightfield h = s.height();
  for (float z : h.z)
    if (!std::isfinite(z)) throw RequestError(400, "/op: this operation gives non-finite elevations");
  m_preview_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return h;
}

}  // namespace terracl::studio
