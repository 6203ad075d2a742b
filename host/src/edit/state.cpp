#include "edit/state.hpp"
#include "edit/ops_erode.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

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
  // The template only carries georef/metadata/mean; its arrays are reused for downloads.
}

size_t EditState::hard_count() const {
  return size_t(std::count_if(m_hard.begin(), m_hard.end(), [](float v) { return !std::isnan(v); }));
}

void EditState::clear_hard() {
  std::fill(m_hard.begin(), m_hard.end(), std::numeric_limits<float>::quiet_NaN());
  m_stale = true;
}

GradientField EditState::download() {
  m_buf.download(m_device, m_template);
  return m_template;
}

void EditState::upload(const GradientField& g) {
  const size_t bytes = g.size() * sizeof(float);
  m_device.queue().enqueueWriteBuffer(m_buf.gx, CL_FALSE, 0, bytes, g.gx.data());
  m_device.queue().enqueueWriteBuffer(m_buf.gy, CL_TRUE, 0, bytes, g.gy.data());
  m_stale = true;
}

const Heightfield& EditState::height() {
  if (m_stale || !m_solution) solve();
  return *m_solution;
}

const Heightfield& EditState::solve(bool warm) {
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
  m_stale = false;
  ++m_solves;
  return *m_solution;
}

// ---- geometry ----

std::vector<Vec2> xy(const std::vector<Vec3>& pts) {
  std::vector<Vec2> out;
  for (const auto& p : pts) out.push_back({p.x, p.y});
  return out;
}

Region parse_region(Params& p, bool allow_everywhere) {
  Region r;
  const bool disc = p.has("center"), poly = p.has("polygon");
  if (disc && poly) param_error(p.path(), "give either center + radius (a disc) or polygon, not both");
  if (disc) {
    r.kind = Region::Disc;
    r.center = p.point("center");
    r.radius = p.hlength("radius", {}, 0, true);
  } else if (poly) {
    r.kind = Region::Polygon;
    r.polygon = xy(p.points("polygon", 3));
  } else if (!allow_everywhere) {
    param_error(p.path(), "needs a region: center + radius (a disc) or polygon");
  }
  return r;
}

Primitive region_primitive(const Region& r, const Grid& g, double falloff) {
  Primitive p;
  p.radius = falloff;
  if (r.kind == Region::Disc) {
    p.shape = PrimitiveShape::Disc;
    p.points = {r.center};
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
    if (r.kind == Region::Polygon) {
      bx0 = by0 = 1e300, bx1 = by1 = -1e300;
      for (const auto& v : r.polygon) bx0 = std::min(bx0, v.x), bx1 = std::max(bx1, v.x), by0 = std::min(by0, v.y), by1 = std::max(by1, v.y);
    }
    x0 = std::max(x0, int(std::floor(bx0 / g.cell_x))), x1 = std::min(x1, int(std::ceil(bx1 / g.cell_x)));
    y0 = std::max(y0, int(std::floor(by0 / g.cell_y))), y1 = std::min(y1, int(std::ceil(by1 / g.cell_y)));
  }
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double px = x * g.cell_x, py = y * g.cell_y;
      bool in = r.kind == Region::Everywhere;
      if (r.kind == Region::Disc) in = std::hypot(px - r.center.x, py - r.center.y) <= r.radius;
      if (r.kind == Region::Polygon) in = inside_polygon(r.polygon, px, py);
      if (in) out.push_back(size_t(y) * g.width + x);
    }
  return out;
}

void rasterize_polyline(EditState& s, const std::vector<Vec3>& pts, double width) {
  const Grid& g = s.grid();
  const double half = std::max(width / 2, 0.5 * std::max(g.cell_x, g.cell_y));
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : pts) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  const int cx0 = std::max(0, int(std::floor((x0 - half) / g.cell_x))), cx1 = std::min(g.width - 1, int(std::ceil((x1 + half) / g.cell_x)));
  const int cy0 = std::max(0, int(std::floor((y0 - half) / g.cell_y))), cy1 = std::min(g.height - 1, int(std::ceil((y1 + half) / g.cell_y)));
  if (cx1 < cx0 || cy1 < cy0) return;
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
    const int x0r = std::max(cx0, int(std::floor(rx0 / g.cell_x))), x1r = std::min(cx1, int(std::ceil(rx1 / g.cell_x)));
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
      if (best <= half) s.set_hard(size_t(y) * g.width + x, float(z));
    }
  }
  s.changed();
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
    add_composite_ops(v);
    add_paste_ops(v);
    add_fit_ops(v);
    add_erode_ops(v);
    return v;
  }();
  return ops;
}

}  // namespace terracl::edit
