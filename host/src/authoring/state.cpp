// SPDX-License-Identifier: Apache-2.0
#include "authoring/state.hpp"
#include "authoring/ops_erode.hpp"

#include "authoring/locality.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>

namespace terracl::edit {

EditState::EditState(Device& d, const GradientField& g0, std::optional<Heightfield> h0, SolverOptions solver)
    : m_device(d), m_template(g0), m_solution(std::move(h0)), m_solver(std::move(solver)) {
  m_grid.width = g0.width;
  m_grid.height = g0.height;
  m_grid.cell_x = g0.georef.cell_x;
  m_grid.cell_y = g0.georef.cell_y;
  m_buf = GradientBuffers::upload(d, g0);
  m_hard.assign(g0.size(), std::numeric_limits<float>::quiet_NaN());
  m_stale = !m_solution.has_value();
  if (m_solution) {  // the base of local solves
    m_base = *m_solution;
    m_base_gx = g0.gx;
    m_base_gy = g0.gy;
    // A base with relief is the "local" style's exemplar (landform_detail.cpp); a level one has none.
    const auto [lo, hi] = std::minmax_element(m_base.z.begin(), m_base.z.end());
    if (lo != m_base.z.end() && *hi - *lo > 1.0f) m_start = std::make_shared<const Heightfield>(m_base);
  }
  // The template only carries georef/metadata/mean; its arrays are reused for downloads.
}

std::unique_ptr<EditState> EditState::clone() const {
  // The host state by member-wise copy; the device buffers (shared handles after that copy) are
  // then replaced by copies of their contents.
  auto c = std::unique_ptr<EditState>(new EditState(*this));
  const GradientBuffers& b = m_buf;
  GradientBuffers& n = c->m_buf;
  const size_t bytes = b.cells() * sizeof(float);
  auto& q = m_device.queue();
  auto copy = [&](const cl::Buffer& from, const char* what) {
    if (!from()) return cl::Buffer();
    cl::Buffer to = m_device.buffer(bytes, CL_MEM_READ_WRITE, what);
    q.enqueueCopyBuffer(from, to, 0, 0, bytes);
    return to;
  };
  n.gx = copy(b.gx, "gradient x");
  n.gy = copy(b.gy, "gradient y");
  n.tx = copy(b.tx, "scratch x");
  n.ty = copy(b.ty, "scratch y");
  n.mask = copy(b.mask, "mask");
  n.nv = copy(b.nv, "noise values");
  n.nx = copy(b.nx, "noise d/dx");
  n.ny = copy(b.ny, "noise d/dy");
  n.skeleton.reset();  // a parameter upload buffer, rewritten by every tensor operation
  q.finish();
  return c;
}

double EditState::falloff() const {
  if (m_falloff) return *m_falloff;
  return std::max(kFalloffPerReach * m_reach, kMinFalloffCells * std::max(m_grid.cell_x, m_grid.cell_y));
}

void EditState::rebase() {
  if (!m_solution || m_stale) solve();
  m_base = *m_solution;
  if (m_field_changed) sync_field();  // a local solve left the current field in m_template
  m_base_gx = m_template.gx;
  m_base_gy = m_template.gy;
  // Every change so far is in the base now: later local solves see only their own operations.
  m_supports.clear();
}

size_t EditState::hard_count() const {
  return size_t(std::count_if(m_hard.begin(), m_hard.end(), [](float v) { return !std::isnan(v); }));
}

void EditState::clear_hard() {
  std::fill(m_hard.begin(), m_hard.end(), std::numeric_limits<float>::quiet_NaN());
  m_stale = true;
}

GradientField EditState::download() { return sync_field(); }

const GradientField& EditState::sync_field() {
  m_buf.download(m_device, m_template);
  return m_template;
}

void EditState::upload(const GradientField& g) {
  const size_t bytes = g.size() * sizeof(float);
  m_device.queue().enqueueWriteBuffer(m_buf.gx, CL_FALSE, 0, bytes, g.gx.data());
  m_device.queue().enqueueWriteBuffer(m_buf.gy, CL_TRUE, 0, bytes, g.gy.data());
  m_stale = m_field_changed = true;
}

const Heightfield& EditState::height() {
  if (m_stale || !m_solution) solve();
  return *m_solution;
}

const Heightfield& EditState::solve(bool warm) {
  if (m_local && !m_base.z.empty()) {
    solve_local(warm);
    m_stale = false;
    ++m_solves;
    return *m_solution;
  }
  m_locality = {{"mode", "global"}};
  solve_global(warm);
  m_stale = false;
  ++m_solves;
  return *m_solution;
}

void EditState::solve_global(bool warm) {
  // The field stays on the device: the solve reads m_buf directly (m_template gives georef,
  // metadata and mean only).
  ConstraintSet cs(m_grid.width, m_grid.height);
  for (size_t i = 0; i < m_hard.size(); ++i)
    if (!std::isnan(m_hard[i]))
      cs.add_cell(int(i % size_t(m_grid.width)), int(i / size_t(m_grid.width)), m_hard[i], ConstraintKind::Raster, "edit");
  SolverOptions o = m_solver;
  o.initial = warm && m_solution ? &*m_solution : nullptr;
  m_last = reconstruct_device(m_device, m_buf.gx, m_buf.gy, m_template, cs, o);
  m_solution = std::move(m_last.height);
  m_last.height = Heightfield();
  m_solution->georef = m_template.georef;
  if (cs.empty()) keep_far_field_level();
}

void EditState::keep_far_field_level() {
  // Without a hard cell the solve fixes the level by the mean elevation, so a raised ridge would
  // lower the whole plain around it. The far field (cells more than two cells from any changed
  // face) keeps the base's level instead; with no far field left, the mean stays the gauge.
  const int W = m_grid.width, H = m_grid.height;
  const size_t N = size_t(W) * size_t(H);
  if (m_base.z.size() != N || m_base_gx.size() != N || m_solution->z.size() != N) return;
  sync_field();
  const std::vector<float>&gx = m_template.gx, &gy = m_template.gy;
  std::vector<uint8_t> near(N, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      if (gx[i] != m_base_gx[i]) near[i] = 1, near[i + (x + 1 < W ? 1 : 0)] = 1;
      if (gy[i] != m_base_gy[i]) near[i] = 1, near[i + (y + 1 < H ? size_t(W) : 0)] = 1;
    }
  constexpr int kMargin = 2;
  std::vector<uint8_t> row(N, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int k = std::max(0, x - kMargin); k <= std::min(W - 1, x + kMargin) && !row[size_t(y) * W + x]; ++k)
        row[size_t(y) * W + x] = near[size_t(y) * W + k];
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool touched = false;
      for (int k = std::max(0, y - kMargin); k <= std::min(H - 1, y + kMargin) && !touched; ++k) touched = row[size_t(k) * W + x];
      if (touched) continue;
      const size_t i = size_t(y) * W + x;
      sum += double(m_solution->z[i]) - double(m_base.z[i]);
      ++n;
    }
  if (n < N / 100) return;
  const float shift = float(sum / double(n));
  for (float& z : m_solution->z) z -= shift;
  m_locality["far_field_cells"] = n;
}

void EditState::solve_local(bool warm) {
  const int W = m_grid.width, H = m_grid.height;
  const size_t N = size_t(W) * size_t(H);
  const double cx = m_grid.cell_x, cy = m_grid.cell_y;
  const auto t0 = std::chrono::steady_clock::now();
  sync_field();
  m_field_changed = false;
  const std::vector<float>&gx = m_template.gx, &gy = m_template.gy;
  // Changed cells: a changed face changes the divergence of both cells it separates; a hard cell
  // changes the terrain only where it differs from the base (freeze holds, it does not move).
  // Scratch kept between solves (members): a fresh N-cell vector per solve costs its page faults and
  // the kernel's zeroing, more than the loops over it at 2049^2.
  std::vector<uint8_t>& changed = m_scratch_changed;
  changed.assign(N, 0);
  size_t n_changed = 0;
  int bx0 = W, by0 = H, bx1 = -1, by1 = -1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      bool c = false;
      if (gx[i] != m_base_gx[i]) {
        c = true;
        if (x + 1 < W) changed[i + 1] = 1;
      }
      if (gy[i] != m_base_gy[i]) {
        c = true;
        if (y + 1 < H) changed[i + W] = 1;
      }
      if (!std::isnan(m_hard[i]) && m_hard[i] != m_base.z[i]) c = true;
      if (c) changed[i] = 1;
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (changed[size_t(y) * W + x]) {
        ++n_changed;
        bx0 = std::min(bx0, x), bx1 = std::max(bx1, x), by0 = std::min(by0, y), by1 = std::max(by1, y);
      }
  const double F = falloff();
  m_locality = {{"mode", "local"}, {"falloff_m", F}, {"changed_cells", n_changed}};
  // The result starts as the base, in the previous solution's storage (no new 4-byte-a-cell block);
  // taken once the warm start has read that solution.
  const auto base_result = [this] {
    Heightfield h;
    if (m_solution) h = std::move(*m_solution);
    h.width = m_base.width, h.height = m_base.height;
    h.z.assign(m_base.z.begin(), m_base.z.end());
    h.georef = m_template.georef;
    h.metadata = m_base.metadata;
    return h;
  };
  m_last = ReconstructResult();
  if (n_changed == 0) {  // nothing moved (or only holds at the base elevation)
    m_locality["solved_cells"] = 0;
    m_solution = base_result();
    return;
  }
  // The region: every cell within its falloff of a changed cell. Each operation's changed cells
  // (those inside its support box) fade over that operation's own falloff, so one wide brush does
  // not widen the fade of a thin stroke elsewhere; an explicit "falloff", or changed cells in no
  // box, use F. One exact distance transform per distinct falloff, on the changed box grown by it.
  // wt: the taper weight (1 in the inner half of the band, C2 to 0 at its edge; max over groups).
  std::vector<std::pair<double, std::vector<Support>>> groups;
  std::vector<uint8_t>& covered = m_scratch_covered;
  covered.clear();
  if (!m_falloff && !m_supports.empty()) {
    covered.assign(N, 0);
    const double min_f = kMinFalloffCells * std::max(cx, cy);
    for (const Support& sp : m_supports) {
      const double f = std::max(kFalloffPerReach * sp.reach, min_f);
      auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == f; });
      if (it == groups.end()) groups.push_back({f, {}}), it = groups.end() - 1;
      it->second.push_back(sp);
    }
  }
  std::vector<float>& wt = m_scratch_wt;
  wt.assign(N, 0.f);
  std::vector<uint8_t>& omega = m_scratch_omega;
  omega.assign(N, 0);
  std::vector<uint8_t> src;
  double f_max = 0;
  auto dilate = [&](double f, const std::function<bool(int, int)>& take) {
    int sx0 = W, sy0 = H, sx1 = -1, sy1 = -1;
    for (int y = by0; y <= by1; ++y)
      for (int x = bx0; x <= bx1; ++x)
        if (changed[size_t(y) * W + x] && take(x, y))
          sx0 = std::min(sx0, x), sx1 = std::max(sx1, x), sy0 = std::min(sy0, y), sy1 = std::max(sy1, y);
    if (sx1 < 0) return;
    f_max = std::max(f_max, f);
    const int mx = cell_index(std::ceil(f / cx)) + 1, my = cell_index(std::ceil(f / cy)) + 1;
    const int ex0 = std::max(0, sx0 - mx), ex1 = std::min(W - 1, sx1 + mx), ey0 = std::max(0, sy0 - my), ey1 = std::min(H - 1, sy1 + my);
    const int ew = ex1 - ex0 + 1, eh = ey1 - ey0 + 1;
    src.assign(size_t(ew) * eh, 0);
    for (int y = std::max(ey0, sy0); y <= std::min(ey1, sy1); ++y)
      for (int x = std::max(ex0, sx0); x <= std::min(ex1, sx1); ++x)
        src[size_t(y - ey0) * ew + x - ex0] = changed[size_t(y) * W + x] && take(x, y);
    const std::vector<float> d2 = squared_distance(src, ew, eh, cx, cy);
    const float f2 = float(f * f);
    for (int y = 0; y < eh; ++y)
      for (int x = 0; x < ew; ++x) {
        const float e = d2[size_t(y) * ew + x];
        if (!(e <= f2)) continue;
        const size_t i = size_t(y + ey0) * W + x + ex0;
        omega[i] = 1;
        // The harmonic fade meets the Dirichlet border with a kink (a visible crease in
        // hillshades); the outer half of the band tapers it so the change reaches zero with zero
        // slope. The band holds no changed cell, so no edit is altered.
        const double t = std::clamp((std::sqrt(double(e)) - 0.5 * f) / (0.5 * f), 0.0, 1.0);
        wt[i] = std::max(wt[i], float(1 - t * t * t * (t * (t * 6 - 15) + 10)));
      }
  };
  // One distance transform per group costs its window; when the groups' windows add up to more
  // than twice the grid (edits spread over the whole map, as in the benchmark), one transform with
  // the largest falloff (a wider fade, still local) is cheaper than the per-operation ones.
  double work = 0;
  for (const auto& [f, boxes] : groups) {
    int x0 = W, y0 = H, x1 = -1, y1 = -1;
    for (const Support& b : boxes) x0 = std::min(x0, b.x0), y0 = std::min(y0, b.y0), x1 = std::max(x1, b.x1), y1 = std::max(y1, b.y1);
    const double gw = std::min(double(W), x1 - x0 + 1 + 2 * f / cx), gh = std::min(double(H), y1 - y0 + 1 + 2 * f / cy);
    work += std::max(0.0, gw) * std::max(0.0, gh);
  }
  if (groups.size() > 1 && work > 2.0 * double(N)) groups.clear();
  for (const auto& [f, boxes] : groups) {
    dilate(f, [&, &bx = boxes](int x, int y) {
      for (const Support& b : bx)
        if (x >= b.x0 - 2 && x <= b.x1 + 2 && y >= b.y0 - 2 && y <= b.y1 + 2) return true;
      return false;
    });
    for (const Support& b : boxes)
      for (int y = std::max(0, b.y0 - 2); y <= std::min(H - 1, b.y1 + 2); ++y)
        std::fill(covered.begin() + size_t(y) * W + std::max(0, b.x0 - 2), covered.begin() + size_t(y) * W + std::min(W - 1, b.x1 + 2) + 1, 1);
  }
  if (groups.empty()) dilate(F, [](int, int) { return true; });
  else dilate(F, [&](int x, int y) { return !covered[size_t(y) * W + x]; });  // changed cells in no box
  m_locality["falloff_m"] = f_max;
  std::vector<double> fs;
  for (const auto& g : groups) fs.push_back(g.first);
  if (!fs.empty()) m_locality["falloffs_m"] = fs;
  size_t n_omega = 0;
  int ox0 = W, oy0 = H, ox1 = -1, oy1 = -1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (omega[size_t(y) * W + x]) {
        ++n_omega;
        ox0 = std::min(ox0, x), ox1 = std::max(ox1, x), oy0 = std::min(oy0, y), oy1 = std::max(oy1, y);
      }
  if (n_omega == N) {
    // The region is the whole grid (whole-grid support, or edits everywhere): the change has no
    // Dirichlet border, and solving for dh with the mean kept is the global solve of h, which
    // reads the field on the device (no window to copy).
    m_locality["solved_cells"] = n_omega;
    m_locality["window"] = {0, 0, W, H};
    m_locality["prepare_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    solve_global(warm);
    return;
  }
  // The window: the region's box plus one cell, so every region cell's in-grid neighbours are in
  // it (the window's own border is then either the grid's border, Neumann as in a global solve,
  // or a Dirichlet cell outside the region).
  const int wx0 = std::max(0, ox0 - 1), wx1 = std::min(W - 1, ox1 + 1), wy0 = std::max(0, oy0 - 1), wy1 = std::min(H - 1, oy1 + 1);
  const int ww = wx1 - wx0 + 1, wh = wy1 - wy0 + 1;
  // The change of the field dg and of the hard values over the window; the solve returns dh.
  GradientField dg(ww, wh);
  dg.georef.cell_x = cx, dg.georef.cell_y = cy;
  dg.mean_elevation = 0;  // with no hard cell at all (whole-grid support): the mean does not move
  ConstraintSet cs(ww, wh);
  for (int y = 0; y < wh; ++y)
    for (int x = 0; x < ww; ++x) {
      const size_t j = size_t(y) * ww + x, i = size_t(y + wy0) * W + x + wx0;
      dg.gx[j] = float(double(gx[i]) - double(m_base_gx[i]));
      dg.gy[j] = float(double(gy[i]) - double(m_base_gy[i]));
      if (!omega[i]) cs.add_cell(x, y, 0.0, ConstraintKind::Raster, "locality");
      else if (!std::isnan(m_hard[i])) cs.add_cell(x, y, double(m_hard[i]) - double(m_base.z[i]), ConstraintKind::Raster, "edit");
    }
  SolverOptions o = m_solver;
  o.mean = 0.0;
  Heightfield init;
  if (warm && m_solution) {  // the previous change over this window
    init = Heightfield(ww, wh);
    for (int y = 0; y < wh; ++y)
      for (int x = 0; x < ww; ++x) {
        const size_t i = size_t(y + wy0) * W + x + wx0;
        init.z[size_t(y) * ww + x] = float(double(m_solution->z[i]) - double(m_base.z[i]));
      }
    o.initial = &init;
  } else {
    o.initial = nullptr;
  }
  const double prep_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const auto t_solve = std::chrono::steady_clock::now();
  m_last = reconstruct(m_device, dg, cs, o);
  m_locality["solve_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_solve).count();
  const Heightfield& dh = m_last.height;
  Heightfield h = base_result();
  for (int y = 0; y < wh; ++y)
    for (int x = 0; x < ww; ++x) {
      const size_t i = size_t(y + wy0) * W + x + wx0;
      if (!omega[i]) continue;  // the base, bit for bit
      if (!std::isnan(m_hard[i])) {
        h.z[i] = m_hard[i];
        continue;
      }
      const double w = wt[i];
      h.z[i] = float(double(m_base.z[i]) + w * double(dh.z[size_t(y) * ww + x]));
    }
  m_last.height = Heightfield();
  m_last.total_ms += prep_ms;
  m_locality["solved_cells"] = n_omega;
  m_locality["window"] = {wx0, wy0, ww, wh};
  m_locality["prepare_ms"] = prep_ms;
  m_solution = std::move(h);
}

// ---- geometry ----

std::vector<Vec2> xy(const std::vector<Vec3>& pts) {
  std::vector<Vec2> out;
  for (const auto& p : pts) out.push_back({p.x, p.y});
  return out;
}

Region parse_region(Params& p, bool allow_everywhere) {
  Region r;
  const bool disc = p.has("center"), poly = p.has("polygon"), path = p.has("path");
  if (int(disc) + int(poly) + int(path) > 1)
    param_error(p.path(), "give one region: center + radius (a disc), polygon, or path + radius (a painted stroke)");
  if (path) {
    // A painted brush stroke: one vertex is a disc (the same operation, bit for bit).
    const std::vector<Vec2> pts = xy(p.points("path", 1));
    r.radius = p.hlength("radius", {}, 0, true);
    if (pts.size() == 1) {
      r.kind = Region::Disc;
      r.center = pts[0];
    } else {
      r.kind = Region::Path;
      r.path = pts;
    }
  } else if (disc) {
    r.kind = Region::Disc;
    r.center = p.point("center");
    r.radius = p.hlength("radius", {}, 0, true);
  } else if (poly) {
    r.kind = Region::Polygon;
    r.polygon = xy(p.points("polygon", 3));
  } else if (!allow_everywhere) {
    param_error(p.path(), "needs a region: center + radius (a disc), polygon, or path + radius (a painted stroke)");
  }
  return r;
}

namespace {
double segment_distance(const Vec2& a, const Vec2& b, double x, double y) {
  const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
  const double t = l2 > 0 ? std::clamp(((x - a.x) * ux + (y - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
  return std::hypot(x - a.x - t * ux, y - a.y - t * uy);
}
bool inside_polygon(const std::vector<Vec2>& poly, double x, double y);
}  // namespace

double Region::distance(double x, double y) const {
  switch (kind) {
    case Everywhere: return 0;
    case Disc: return std::max(0.0, std::hypot(x - center.x, y - center.y) - radius);
    case Polygon: return inside_polygon(polygon, x, y) ? 0.0 : std::numeric_limits<double>::infinity();
    case Path: {
      double d = std::numeric_limits<double>::infinity();
      for (size_t i = 0; i + 1 < path.size(); ++i) d = std::min(d, segment_distance(path[i], path[i + 1], x, y));
      return std::max(0.0, d - radius);
    }
  }
  return 0;
}

HostRegion region_on_host(EditState& s, const Region& r, double falloff) {
  GradientBuffers& b = s.buffers();
  const Primitive region = region_primitive(r, s.grid(), falloff);
  HostRegion hr;
  hr.box = primitives_box({region}, b.width, b.height, b.cell_x, b.cell_y);
  if (hr.box.empty()) return hr;
  const Box& box = hr.box;
  primitive_weight(s.device(), b, {region}, box, false);
  hr.w.resize(size_t(box.w) * box.h);
  const std::array<size_t, 3> origin{size_t(box.x0) * sizeof(float), size_t(box.y0), 0}, host{0, 0, 0};
  const std::array<size_t, 3> extent{size_t(box.w) * sizeof(float), size_t(box.h), 1};
  s.device().queue().enqueueReadBufferRect(b.mask, CL_TRUE, origin, host, extent, size_t(b.width) * sizeof(float), 0,
                                           size_t(box.w) * sizeof(float), 0, hr.w.data());
  return hr;
}

Primitive region_primitive(const Region& r, const Grid& g, double falloff) {
  Primitive p;
  p.radius = falloff;
  if (r.kind == Region::Disc) {
    p.shape = PrimitiveShape::Disc;
    p.points = {r.center};
    p.disc_radius = r.radius;
  } else if (r.kind == Region::Path) {
    // The band around the polyline weighs 1 out to disc_radius (tensor.cl, prim_weight_v).
    p.shape = PrimitiveShape::Polyline;
    p.points = r.path;
    p.disc_radius = r.radius;
  } else {
    p.shape = PrimitiveShape::Polygon;
    if (r.kind == Region::Polygon) {
      p.points = r.polygon;
    } else {
      const double X = (g.width + 1) * g.cell_x, Y = (g.height + 1) * g.cell_y;
      p.points = {{-g.cell_x, -g.cell_y}, {X, -g.cell_y}, {X, Y}, {-g.cell_x, Y}};
    }
  }
  return p;
}

namespace {
bool inside_polygon(const std::vector<Vec2>& poly, double x, double y) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 &a = poly[i], &b = poly[j];
    if ((a.y <= y) != (b.y <= y) && x < a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x)) in = !in;
  }
  return in;
}
}  // namespace

std::vector<size_t> region_cells(const Region& r, const Grid& g) {
  std::vector<size_t> out;
  int x0 = 0, y0 = 0, x1 = g.width - 1, y1 = g.height - 1;
  if (r.kind != Region::Everywhere) {  // only the cells of the region's bounding box
    double bx0 = r.center.x - r.radius, bx1 = r.center.x + r.radius, by0 = r.center.y - r.radius, by1 = r.center.y + r.radius;
    if (r.kind == Region::Polygon || r.kind == Region::Path) {
      const double m = r.kind == Region::Path ? r.radius : 0.0;
      bx0 = by0 = 1e300, bx1 = by1 = -1e300;
      for (const auto& v : r.kind == Region::Path ? r.path : r.polygon)
        bx0 = std::min(bx0, v.x - m), bx1 = std::max(bx1, v.x + m), by0 = std::min(by0, v.y - m), by1 = std::max(by1, v.y + m);
    }
    x0 = std::max(x0, cell_index(std::floor(bx0 / g.cell_x))), x1 = std::min(x1, cell_index(std::ceil(bx1 / g.cell_x)));
    y0 = std::max(y0, cell_index(std::floor(by0 / g.cell_y))), y1 = std::min(y1, cell_index(std::ceil(by1 / g.cell_y)));
  }
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double px = x * g.cell_x, py = y * g.cell_y;
      bool in = r.kind == Region::Everywhere;
      if (r.kind == Region::Disc) in = std::hypot(px - r.center.x, py - r.center.y) <= r.radius;
      if (r.kind == Region::Polygon) in = inside_polygon(r.polygon, px, py);
      if (r.kind == Region::Path) in = r.distance(px, py) <= 0;
      if (in) out.push_back(size_t(y) * g.width + x);
    }
  return out;
}

void rasterize_polyline(EditState& s, const std::vector<Vec3>& pts, double width) {
  const Grid& g = s.grid();
  const double half = std::max(width / 2, 0.5 * std::max(g.cell_x, g.cell_y));
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : pts) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  const int cx0 = std::max(0, cell_index(std::floor((x0 - half) / g.cell_x))), cx1 = std::min(g.width - 1, cell_index(std::ceil((x1 + half) / g.cell_x)));
  const int cy0 = std::max(0, cell_index(std::floor((y0 - half) / g.cell_y))), cy1 = std::min(g.height - 1, cell_index(std::ceil((y1 + half) / g.cell_y)));
  if (cx1 < cx0 || cy1 < cy0) return;
  const Heightfield* ground = s.last_solution();
  double cut = 0, fill = 0;
  size_t n = 0;
  for (int y = cy0; y <= cy1; ++y) {
    // Only the columns near some segment in this row (a diagonal curve's box is mostly empty): the
    // x-extent of each segment's part within `half` of the row, widened by `half` and one cell.
    const double py = y * g.cell_y;
    double rx0 = 1e300, rx1 = -1e300;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
      const Vec3 &a = pts[i], &b = pts[i + 1];
      const double uy = b.y - a.y;
      double t0 = 0, t1 = 1;
      if (uy != 0) {
        t0 = (py - half - a.y) / uy, t1 = (py + half - a.y) / uy;
        if (t0 > t1) std::swap(t0, t1);
        t0 = std::max(t0, 0.0), t1 = std::min(t1, 1.0);
        if (t0 > t1) continue;
      } else if (std::abs(py - a.y) > half + g.cell_y) {
        continue;
      }
      const double xa = a.x + t0 * (b.x - a.x), xb = a.x + t1 * (b.x - a.x);
      rx0 = std::min(rx0, std::min(xa, xb) - half - g.cell_x), rx1 = std::max(rx1, std::max(xa, xb) + half + g.cell_x);
    }
    if (rx0 > rx1) continue;
    const int x0r = std::max(cx0, cell_index(std::floor(rx0 / g.cell_x))), x1r = std::min(cx1, cell_index(std::ceil(rx1 / g.cell_x)));
    for (int x = x0r; x <= x1r; ++x) {
      const double px = x * g.cell_x;
      double best = 1e300, z = 0;
      for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const Vec3 &a = pts[i], &b = pts[i + 1];
        const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
        const double t = l2 > 0 ? std::clamp(((px - a.x) * ux + (py - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
        const double d = std::hypot(px - a.x - t * ux, py - a.y - t * uy);
        if (d < best) best = d, z = a.z + t * (b.z - a.z);
      }
      if (best <= half) {
        const size_t i = size_t(y) * g.width + x;
        s.set_hard(i, float(z));
        if (ground && std::isfinite(ground->z[i])) cut = std::max(cut, double(ground->z[i]) - z), fill = std::max(fill, z - double(ground->z[i])), ++n;
      }
    }
  }
  s.changed();
  // Hard constraints replace the terrain: say so when they cut the existing relief by more than
  // kCutWarning (a crest drawn below a range planes the range; a dam raising a valley is meant).
  constexpr double kCutWarning = 10.0;
  if (n && cut > kCutWarning && !s.log().empty()) {
    auto& e = s.log().back();
    if (e.contains("constraint_cut_m")) {  // one warning per operation (fit rasterizes many curves)
      cut = std::max(cut, e["constraint_cut_m"].get<double>()), fill = std::max(fill, e["constraint_fill_m"].get<double>());
    } else {
      if (!e.contains("warnings")) e["warnings"] = nlohmann::json::array();
      e["warnings"].push_back(fmt::format(
        "operation {} ({}): its elevation constraints cut into the terrain under them by up to {:.0f} m; leave out "
        "`elevation` to place the stroke relative to the ground",
          e.value("index", 0), e.value("op", std::string()), cut));
    }
    e["constraint_cut_m"] = cut;
    e["constraint_fill_m"] = fill;
  }
}

double curl_rms(const GradientField& g) {
  const int W = g.width, H = g.height;
  double s = 0;
  size_t n = 0;
  for (int y = 0; y + 1 < H; ++y)
    for (int x = 0; x + 1 < W; ++x) {
      const size_t o = size_t(y) * W + x;
      const double c = (g.gx[o + W] - g.gx[o]) / g.georef.cell_y - (g.gy[o + 1] - g.gy[o]) / g.georef.cell_x;
      s += c * c;
      ++n;
    }
  return n ? std::sqrt(s / double(n)) : 0.0;
}

const std::vector<OpSpec>& operations() {
  static const std::vector<OpSpec> ops = [] {
    std::vector<OpSpec> v;
    add_brush_ops(v);
    add_curve_ops(v);
    add_landform_ops(v);
    add_style_ops(v);
    add_composite_ops(v);
    add_paste_ops(v);
    add_fit_ops(v);
    add_erode_ops(v);
    add_amplify_ops(v);
    add_strata_ops(v);
    add_drainage_ops(v);
    add_lake_ops(v);
    return v;
  }();
  return ops;
}

}  // namespace terracl::edit
