// SPDX-License-Identifier: Apache-2.0
// Hard-constraint rasterisation and the constraint JSON format (priority rule in constraints.hpp).
#include <terracl/constraints.hpp>
#include <terracl/amplify.hpp>  // parallel_for
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <unordered_map>

namespace terracl {

ConstraintSet::ConstraintSet(int width, int height)
    : m_width(width), m_height(height), m_kind(size_t(width) * height, 0), m_sum(size_t(width) * height, 0.f),
      m_count(size_t(width) * height, 0) {
  if (width < 0 || height < 0) fail("constraints", "negative grid size {}x{}", width, height);
  m_rows = height;
}

ConstraintSet ConstraintSet::band(int width, int height, int row0, int rows) {
  if (row0 < 0 || rows < 0 || row0 + rows > height)
    fail("constraints", "band of rows [{}, {}) outside the {}x{} grid", row0, row0 + rows, width, height);
  ConstraintSet c(width, rows);
  c.m_height = height;
  c.m_row0 = row0;
  return c;
}

void ConstraintSet::check_band_field(const Heightfield& h, const char* what, const std::string& where) const {
  if (h.width != m_width || h.height != m_rows)
    fail("constraints", "{}: {} is {}x{}, the grid {}x{}", where, what, h.width, h.height, m_width, m_rows);
}

size_t ConstraintSet::count() const {
  return size_t(std::count_if(m_kind.begin(), m_kind.end(), [](uint8_t k) { return k != 0; }));
}

float ConstraintSet::value(int x, int y) const {
  const size_t i = index(x, y);
  if (!m_kind[i]) return std::numeric_limits<float>::quiet_NaN();
  return m_count[i] == 1 ? m_sum[i] : float(double(m_sum[i]) / m_count[i]);
}

std::vector<float> ConstraintSet::values() const {
  std::vector<float> v(m_kind.size(), std::numeric_limits<float>::quiet_NaN());
  for (size_t i = 0; i < v.size(); ++i)
    if (m_kind[i]) v[i] = m_count[i] == 1 ? m_sum[i] : float(double(m_sum[i]) / m_count[i]);
  return v;
}

namespace {
// hard_cells works in chunks of this many cells, one thread per range of chunks; grids below a
// few chunks stay on the calling thread (as reconstruct.cpp's host passes).
constexpr size_t kHardChunk = size_t(1) << 16;
}  // namespace

void ConstraintSet::hard_cells(std::vector<uint32_t>& index, std::vector<float>& value) const {
  // Each thread scans its own range of chunks into its own lists, which are then joined in chunk
  // order: the list is in row-major order whatever the thread count, each value resolved as before.
  const size_t n = m_kind.size();
  const size_t chunks = std::max<size_t>(1, (n + kHardChunk - 1) / kHardChunk);
  const int threads = n < 4 * kHardChunk ? 1 : 0;
  std::vector<std::vector<uint32_t>> part_index(chunks);
  std::vector<std::vector<float>> part_value(chunks);
  parallel_for(chunks, threads, [&](size_t c0, size_t c1) {
    std::vector<uint32_t>& pi = part_index[c0];
    const size_t e = std::min(n, c1 * kHardChunk);
    size_t i = c0 * kHardChunk;
    for (; i + 8 <= e; i += 8) {  // eight kind bytes at a time: most cells are free
      uint64_t w;
      std::memcpy(&w, m_kind.data() + i, 8);
      if (!w) continue;
      for (size_t k = i; k < i + 8; ++k)
        if (m_kind[k]) pi.push_back(uint32_t(k));
    }
    for (; i < e; ++i)
      if (m_kind[i]) pi.push_back(uint32_t(i));
    std::vector<float>& pv = part_value[c0];
    pv.resize(pi.size());
    for (size_t k = 0; k < pi.size(); ++k) {
      const size_t c = pi[k];
      pv[k] = m_count[c] == 1 ? m_sum[c] : float(double(m_sum[c]) / m_count[c]);
    }
  });
  size_t total = 0;
  for (const auto& p : part_index) total += p.size();
  if (part_index[0].size() == total) {  // one part (one thread, or the others found nothing)
    index = std::move(part_index[0]);
    value = std::move(part_value[0]);
  } else {
    index.clear();
    value.clear();
    index.reserve(total);
    value.reserve(total);
    for (size_t c = 0; c < chunks; ++c) {
      index.insert(index.end(), part_index[c].begin(), part_index[c].end());
      value.insert(value.end(), part_value[c].begin(), part_value[c].end());
    }
  }
  const uint32_t offset = uint32_t(size_t(m_row0) * size_t(m_width));  // band -> whole-grid index
  if (offset)
    for (uint32_t& i : index) i += offset;
}

void ConstraintSet::add_cell(int x, int y, double z, ConstraintKind kind, const std::string& where) {
  if (!std::isfinite(z)) fail("constraints", "{}: elevation must be finite, got {}", where, z);
  if (x < 0 || y < 0 || x >= m_width || y >= m_height)
    fail("constraints", "{}: cell ({}, {}) is outside the {}x{} grid", where, x, y, m_width, m_height);
  if (!in_band(y)) return;  // another band's row
  const size_t i = index(x, y);
  const uint8_t k = uint8_t(kind);
  if (k > m_kind[i]) {  // a more specific kind replaces
    m_kind[i] = k;
    m_sum[i] = float(z);
    m_count[i] = 1;
  } else if (k == m_kind[i] && m_count[i] < 65535) {  // same kind: average
    m_sum[i] += float(z);
    ++m_count[i];
  }
}

void ConstraintSet::add_point(double x, double y, double z, const std::string& where) {
  if (!std::isfinite(x) || !std::isfinite(y)) fail("constraints", "{}: coordinates must be finite", where);
  const double rx = std::floor(x + 0.5), ry = std::floor(y + 0.5);
  if (rx < 0 || ry < 0 || rx >= m_width || ry >= m_height)
    fail("constraints", "{}: point ({}, {}) is outside the {}x{} grid", where, x, y, m_width, m_height);
  add_cell(int(rx), int(ry), z, ConstraintKind::Point, where);
}

void ConstraintSet::add_polyline(const std::vector<std::array<double, 3>>& pts, double width, const std::string& where) {
  if (pts.empty()) fail("constraints", "{}: a polyline needs at least one vertex", where);
  if (!(width > 0) || !std::isfinite(width)) fail("constraints", "{}: width must be positive, got {}", where, width);
  for (size_t k = 0; k < pts.size(); ++k) {
    const auto& p = pts[k];
    const std::string w = fmt::format("{}/points/{}", where, k);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      fail("constraints", "{}: coordinates and z must be finite", w);
    if (p[0] < -0.5 || p[1] < -0.5 || p[0] >= m_width - 0.5 || p[1] >= m_height - 0.5)
      fail("constraints", "{}: vertex ({}, {}) is outside the {}x{} grid", w, p[0], p[1], m_width, m_height);
  }
  const double r = std::max(0.5, width / 2);
  // Nearest point of the whole curve per cell, so that overlapping segments do not double count.
  struct Hit {
    double d2, z;
  };
  std::vector<size_t> cells;
  std::vector<Hit> hits;
  std::unordered_map<size_t, size_t> slot;
  auto consider = [&](int x, int y, double d2, double z) {
    if (x < 0 || y < 0 || x >= m_width || y >= m_height || !in_band(y)) return;
    const size_t i = index(x, y);
    auto [it, fresh] = slot.emplace(i, cells.size());
    if (fresh) {
      cells.push_back(i);
      hits.push_back({d2, z});
    } else if (d2 < hits[it->second].d2) {
      hits[it->second] = {d2, z};
    }
  };
  for (size_t k = 0; k + 1 < std::max<size_t>(pts.size(), 2); ++k) {
    const auto& a = pts[k];
    const auto& b = pts.size() > 1 ? pts[k + 1] : pts[k];
    const double dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
    const int x0 = int(std::floor(std::min(a[0], b[0]) - r)), x1 = int(std::ceil(std::max(a[0], b[0]) + r));
    const int y0 = int(std::floor(std::min(a[1], b[1]) - r)), y1 = int(std::ceil(std::max(a[1], b[1]) + r));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double t = len2 > 0 ? ((x - a[0]) * dx + (y - a[1]) * dy) / len2 : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        const double px = a[0] + t * dx - x, py = a[1] + t * dy - y;
        const double d2 = px * px + py * py;
        // The nearest cell of every point of the curve is always included (connected lines).
        if (d2 <= r * r + 1e-9) consider(x, y, d2, a[2] + t * (b[2] - a[2]));
      }
    const int steps = int(std::ceil(std::sqrt(len2) * 2)) + 1;
    for (int s = 0; s <= steps; ++s) {
      const double t = double(s) / steps;
      const double px = a[0] + t * dx, py = a[1] + t * dy;
      const int cx = int(std::floor(px + 0.5)), cy = int(std::floor(py + 0.5));
      consider(cx, cy, (px - cx) * (px - cx) + (py - cy) * (py - cy), a[2] + t * (b[2] - a[2]));
    }
  }
  for (size_t k = 0; k < cells.size(); ++k)
    add_cell(int(cells[k] % m_width), m_row0 + int(cells[k] / m_width), hits[k].z, ConstraintKind::Polyline, where);
}

std::vector<size_t> ConstraintSet::polygon_cells(const std::vector<std::array<double, 2>>& pts,
                                                 const std::string& where) const {
  if (pts.size() < 3) fail("constraints", "{}: a polygon needs at least 3 vertices, got {}", where, pts.size());
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (size_t k = 0; k < pts.size(); ++k) {
    const auto& p = pts[k];
    const std::string w = fmt::format("{}/points/{}", where, k);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) fail("constraints", "{}: coordinates must be finite", w);
    if (p[0] < -0.5 || p[1] < -0.5 || p[0] >= m_width - 0.5 || p[1] >= m_height - 0.5)
      fail("constraints", "{}: vertex ({}, {}) is outside the {}x{} grid", w, p[0], p[1], m_width, m_height);
    xmin = std::min(xmin, p[0]), xmax = std::max(xmax, p[0]);
    ymin = std::min(ymin, p[1]), ymax = std::max(ymax, p[1]);
  }
  std::vector<size_t> out;
  for (int y = std::max(m_row0, int(std::floor(ymin))); y <= std::min(m_row0 + m_rows - 1, int(std::ceil(ymax))); ++y)
    for (int x = std::max(0, int(std::floor(xmin))); x <= std::min(m_width - 1, int(std::ceil(xmax))); ++x) {
      bool in = false;
      for (size_t i = 0, j = pts.size() - 1; i < pts.size(); j = i++) {
        const auto &a = pts[i], &b = pts[j];
        if ((a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0]) in = !in;
      }
      if (in) out.push_back(index(x, y));
    }
  return out;
}

void ConstraintSet::add_polygon(const std::vector<std::array<double, 2>>& pts, double z, const std::string& where) {
  if (!std::isfinite(z)) fail("constraints", "{}/z: elevation must be finite", where);
  for (size_t i : polygon_cells(pts, where))
    add_cell(int(i % m_width), m_row0 + int(i / m_width), z, ConstraintKind::Polygon, where);
}

void ConstraintSet::add_polygon_freeze(const std::vector<std::array<double, 2>>& pts, const Heightfield& current,
                                       const std::string& where) {
  check_band_field(current, "the current heightfield", where);
  for (size_t i : polygon_cells(pts, where)) {  // band indices: rows of `current`
    const float z = current.z[i];
    if (!std::isfinite(z))
      fail("constraints", "{}: cannot freeze cell ({}, {}): the current elevation is nodata", where, i % m_width,
           m_row0 + i / m_width);
    add_cell(int(i % m_width), m_row0 + int(i / m_width), z, ConstraintKind::Polygon, where);
  }
}

void ConstraintSet::add_rasters(const Heightfield& mask, const Heightfield& elevation, const std::string& where) {
  check_band_field(mask, "mask", where);
  check_band_field(elevation, "elevation raster", where);
  for (int y = m_row0; y < m_row0 + m_rows; ++y)
    for (int x = 0; x < m_width; ++x) {
      const float mv = mask.at(x, y - m_row0);
      if (!std::isfinite(mv) || mv == 0.0f) continue;
      const float z = elevation.at(x, y - m_row0);
      if (!std::isfinite(z))
        fail("constraints", "{}: cell ({}, {}) is fixed by the mask but its elevation is NaN/nodata", where, x, y);
      add_cell(x, y, z, ConstraintKind::Raster, where);
    }
}

void ConstraintSet::add_border(const Heightfield& h, const std::string& where) {
  check_band_field(h, "heightfield", where);
  for (int y = m_row0; y < m_row0 + m_rows; ++y)
    for (int x = 0; x < m_width; ++x)
      if (x == 0 || y == 0 || x == m_width - 1 || y == m_height - 1)
        add_cell(x, y, h.at(x, y - m_row0), ConstraintKind::Raster, where);
}

namespace {

double number(const nlohmann::json& j, const std::string& path) {
  if (!j.is_number()) fail("constraints", "{}: expected a number, got {}", path, j.dump());
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail("constraints", "{}: must be finite", path);
  return v;
}

const nlohmann::json& field(const nlohmann::json& obj, const char* key, const std::string& path) {
  if (!obj.is_object()) fail("constraints", "{}: expected an object, got {}", path, obj.dump());
  if (!obj.contains(key)) fail("constraints", "{}: missing \"{}\"", path, key);
  return obj.at(key);
}

}  // namespace

void add_constraints_json(ConstraintSet& c, const nlohmann::json& doc, const Georef& georef, const Heightfield* current,
                          const std::string& source) {
  if (!doc.is_object()) fail("constraints", "{}: the document must be a JSON object", source);
  for (auto& [k, v] : doc.items())
    if (k != "units" && k != "points" && k != "polylines" && k != "polygons")
      fail("constraints", "{}/{}: unknown key (expected units, points, polylines, polygons)", source, k);
  bool map = false;
  if (doc.contains("units")) {
    const auto& u = doc.at("units");
    if (!u.is_string() || (u != "pixels" && u != "map" && u != "georeferenced"))
      fail("constraints", "{}/units: expected \"pixels\" or \"map\" (alias \"georeferenced\"), got {}", source, u.dump());
    map = u != "pixels";
    if (map && !georef.has_geotransform)
      fail("constraints", "{}/units: \"map\" coordinates need a georeferenced grid, and this one has none", source);
  }
  // Map -> pixel: invert the geotransform (corner convention) and move to cell centres.
  const auto& gt = georef.geotransform;
  const double det = gt[1] * gt[5] - gt[2] * gt[4];
  auto to_pixel = [&](double X, double Y, const std::string& path) -> std::array<double, 2> {
    if (!map) return {X, Y};
    if (det == 0) fail("constraints", "{}: the grid's geotransform is not invertible", path);
    const double dx = X - gt[0], dy = Y - gt[3];
    return {(gt[5] * dx - gt[2] * dy) / det - 0.5, (-gt[4] * dx + gt[1] * dy) / det - 0.5};
  };
  auto array = [&](const nlohmann::json& j, const std::string& path) -> const nlohmann::json& {
    if (!j.is_array()) fail("constraints", "{}: expected an array, got {}", path, j.dump());
    return j;
  };
  // An omitted z is the current elevation at the nearest cell when `current` is known (erosion's
  // kept constraints only need the cells; a reconstruction with --initial keeps the terrain there).
  auto current_z = [&](const std::array<double, 2>& px, const std::string& path) {
    if (!current)
      fail("constraints", "{}: missing z (a number; it may be omitted only where the current elevations are known, "
                          "e.g. with --initial)", path);
    const int x = int(std::lround(px[0])), y = int(std::lround(px[1]));
    const bool band = c.rows() != c.height();  // `current` holds the band's rows only
    const int ch = band ? c.height() : current->height;
    if (x < 0 || y < 0 || x >= current->width || y >= ch)
      fail("constraints", "{}: point ({}, {}) is outside the {}x{} grid", path, px[0], px[1], current->width, ch);
    if (!band) return double(current->at(x, y));
    if (c.in_band(y)) return double(current->at(x, y - c.row0()));
    if (!c.outside_current)
      fail("constraints", "{}: the current elevation of cell ({}, {}) is outside this band of rows", path, x, y);
    return c.outside_current(x, y);
  };
  if (doc.contains("points")) {
    const auto& a = array(doc.at("points"), source + "/points");
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string p = fmt::format("{}/points/{}", source, i);
      // {"x": .., "y": .., "z": ..} or [x, y, z]; z optional with known current elevations.
      double x = 0, y = 0;
      const nlohmann::json* zj = nullptr;
      if (a[i].is_array()) {
        if (a[i].size() != 2 && a[i].size() != 3) fail("constraints", "{}: expected [x, y] or [x, y, z], got {}", p, a[i].dump());
        x = number(a[i][0], p + "/0"), y = number(a[i][1], p + "/1");
        if (a[i].size() == 3) zj = &a[i][2];
      } else {
        x = number(field(a[i], "x", p), p + "/x"), y = number(field(a[i], "y", p), p + "/y");
        if (a[i].contains("z")) zj = &a[i].at("z");
      }
      const auto px = to_pixel(x, y, p);
      c.add_point(px[0], px[1], zj ? number(*zj, p + "/z") : current_z(px, p + "/z"), p);
    }
  }
  if (doc.contains("polylines")) {
    const auto& a = array(doc.at("polylines"), source + "/polylines");
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string p = fmt::format("{}/polylines/{}", source, i);
      const auto& pts = array(field(a[i], "points", p), p + "/points");
      double width = 1;
      if (a[i].contains("width")) width = number(a[i].at("width"), p + "/width");
      if (!(width > 0)) fail("constraints", "{}/width: must be positive, got {}", p, width);
      std::vector<std::array<double, 3>> v;
      for (size_t k = 0; k < pts.size(); ++k) {
        const std::string q = fmt::format("{}/points/{}", p, k);
        if (!pts[k].is_array() || (pts[k].size() != 3 && pts[k].size() != 2))
          fail("constraints", "{}: expected [x, y, z] (or [x, y] where the current elevations are known), got {}", q,
               pts[k].dump());
        const auto px = to_pixel(number(pts[k][0], q + "/0"), number(pts[k][1], q + "/1"), q);
        v.push_back({px[0], px[1], pts[k].size() == 3 ? number(pts[k][2], q + "/2") : current_z(px, q)});
      }
      c.add_polyline(v, width, p);
    }
  }
  if (doc.contains("polygons")) {
    const auto& a = array(doc.at("polygons"), source + "/polygons");
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string p = fmt::format("{}/polygons/{}", source, i);
      const auto& pts = array(field(a[i], "points", p), p + "/points");
      std::vector<std::array<double, 2>> v;
      for (size_t k = 0; k < pts.size(); ++k) {
        const std::string q = fmt::format("{}/points/{}", p, k);
        if (!pts[k].is_array() || pts[k].size() != 2) fail("constraints", "{}: expected [x, y], got {}", q, pts[k].dump());
        v.push_back(to_pixel(number(pts[k][0], q + "/0"), number(pts[k][1], q + "/1"), q));
      }
      // An omitted z freezes the polygon where the current elevations are known.
      static const nlohmann::json kFreeze = "freeze";
      const auto& z = a[i].contains("z") || !current ? field(a[i], "z", p) : kFreeze;
      if (z.is_string()) {
        if (z != "freeze") fail("constraints", "{}/z: expected a number or \"freeze\", got {}", p, z.dump());
        if (!current)
          fail("constraints", "{}/z: \"freeze\" needs the current elevations (give --initial or run after a stage "
                              "that produces a heightfield)", p);
        c.add_polygon_freeze(v, *current, p);
      } else {
        c.add_polygon(v, number(z, p + "/z"), p);
      }
    }
  }
}

void add_constraints_file(ConstraintSet& c, const std::string& path, const Georef& georef, const Heightfield* current) {
  std::ifstream in(path);
  if (!in) fail("constraints", "{}: cannot open the constraint file", path);
  const nlohmann::json doc = read_json_file(path, "constraints");
  add_constraints_json(c, doc, georef, current, path);
}

}  // namespace terracl
