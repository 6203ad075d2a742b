// SPDX-License-Identifier: Apache-2.0
// Heightfield meshes. The simplified mesh is a right-triangulated irregular network (RTIN): the
// square is split recursively at hypotenuse midpoints, which keeps the mesh crack-free as long as
// both triangles sharing a hypotenuse take the same decision (they read the same error entry) and
// a parent splits whenever a child must (errors are propagated upwards). Unlike Martini, whose
// error is only the midpoint's deviation, we store the largest vertical deviation of every grid
// point inside the triangle from its plane, so --max-error is a guarantee.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <regex>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/mesh.hpp>

#include "mesh/mesh_gltf.hpp"

namespace terracl::mesh {

namespace {

struct VertexMap {
  const Heightfield& h;
  std::vector<int64_t> index;  ///< grid cell -> vertex, -1 when not used yet
  Mesh& m;
  VertexMap(const Heightfield& hf, Mesh& mesh) : h(hf), index(hf.size(), -1), m(mesh) {}
  uint32_t get(int x, int y) {
    int64_t& v = index[size_t(y) * h.width + x];
    if (v < 0) {
      v = int64_t(m.positions.size() / 3);
      m.positions.push_back(float(x * h.georef.cell_x));
      m.positions.push_back(h.at(x, y));
      m.positions.push_back(float(y * h.georef.cell_y));
      m.texcoords.push_back(float((x + 0.5) / h.width));
      m.texcoords.push_back(float((y + 0.5) / h.height));
    }
    return uint32_t(v);
  }
};

void check_input(const Heightfield& h) {
  if (h.width < 2 || h.height < 2) fail("mesh", "a mesh needs at least 2 x 2 cells, got {} x {}", h.width, h.height);
  if (h.size() >= (size_t(1) << 31)) fail("mesh", "grid too large for 32-bit indices");
}

}  // namespace

Mesh triangulate_full(const Heightfield& h) {
  check_input(h);
  Mesh m;
  VertexMap vm(h, m);
  for (int y = 0; y + 1 < h.height; ++y)
    for (int x = 0; x + 1 < h.width; ++x) {
      if (std::isnan(h.at(x, y)) || std::isnan(h.at(x + 1, y)) || std::isnan(h.at(x, y + 1)) ||
          std::isnan(h.at(x + 1, y + 1)))
        continue;
      const uint32_t a = vm.get(x, y), b = vm.get(x + 1, y), c = vm.get(x, y + 1), d = vm.get(x + 1, y + 1);
      // Counter-clockwise seen from +Y with X east and Z south: (a, c, b) and (b, c, d).
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  if (m.indices.empty()) fail("mesh", "no 2 x 2 block of valid cells to triangulate");
  return m;
}

Mesh triangulate_simplified(const Heightfield& h, double max_error_m, const Progress& progress) {
  check_input(h);
  const bool holes = std::any_of(h.z.begin(), h.z.end(), [](float v) { return std::isnan(v); });
  return holes ? triangulate_rtin(h, max_error_m, progress) : triangulate_greedy(h, max_error_m, progress);
}

Mesh triangulate_rtin(const Heightfield& h, double max_error_m, const Progress& progress) {
  check_input(h);
  if (!(max_error_m >= 0)) fail("mesh", "max_error must be >= 0 m, got {}", max_error_m);
  int tile = 1;
  while (tile < std::max(h.width, h.height) - 1) tile *= 2;
  const int size = tile + 1;
  auto valid = [&](int x, int y) { return x < h.width && y < h.height && !std::isnan(h.at(x, y)); };
  auto zat = [&](int x, int y) { return double(h.at(x, y)); };
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> errors(size_t(size) * size, 0.f);

  // Triangles are numbered like a binary heap (id 2, 3 are the two halves of the square; the
  // children of id are 2 id and 2 id + 1); finer triangles have larger ids, so walking the ids
  // downwards finishes every child before its parent. The finest level stored here has unit
  // area (hypotenuse 2); its halves, the unit half-squares, need no error of their own.
  const int64_t num_triangles = int64_t(tile) * tile * 2 - 2;
  const int64_t num_parents = num_triangles - int64_t(tile) * tile;
  int64_t reported = 0;
  for (int64_t i = num_triangles - 1; i >= 0; --i) {
    int64_t id = i + 2;
    int ax = 0, ay = 0, bx = 0, by = 0, cx = 0, cy = 0;
    if (id & 1) {
      bx = by = cx = tile;
    } else {
      ax = ay = cy = tile;
    }
    while ((id >>= 1) > 1) {
      const int mx = (ax + bx) >> 1, my = (ay + by) >> 1;
      if (id & 1) {
        bx = ax, by = ay, ax = cx, ay = cy;
      } else {
        ax = bx, ay = by, bx = cx, by = cy;
      }
      cx = mx, cy = my;
    }
    const int mx = (ax + bx) >> 1, my = (ay + by) >> 1;
    float err = 0.f;
    if (!valid(ax, ay) || !valid(bx, by) || !valid(cx, cy)) {
      err = inf;
    } else {
      // Plane through a, b, c: z = za + p (x - ax) + q (y - ay).
      const double za = zat(ax, ay), zb = zat(bx, by), zc = zat(cx, cy);
      const double ux = bx - ax, uy = by - ay, vx = cx - ax, vy = cy - ay;
      const double det = ux * vy - uy * vx;
      const double p = ((zb - za) * vy - (zc - za) * uy) / det, q = ((zc - za) * ux - (zb - za) * vx) / det;
      const int x0 = std::min({ax, bx, cx}), x1 = std::max({ax, bx, cx});
      const int y0 = std::min({ay, by, cy}), y1 = std::max({ay, by, cy});
      double e = 0;
      for (int y = y0; y <= y1 && e != HUGE_VAL; ++y)
        for (int x = x0; x <= x1; ++x) {
          // Inside test with integer edge functions (edges included).
          const long e0 = long(bx - ax) * (y - ay) - long(by - ay) * (x - ax);
          const long e1 = long(cx - bx) * (y - by) - long(cy - by) * (x - bx);
          const long e2 = long(ax - cx) * (y - cy) - long(ay - cy) * (x - cx);
          if (!((e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0))) continue;
          if (!valid(x, y)) {
            e = HUGE_VAL;
            break;
          }
          e = std::max(e, std::abs(zat(x, y) - (za + p * (x - ax) + q * (y - ay))));
        }
      err = e == HUGE_VAL ? inf : float(e);
    }
    const size_t mi = size_t(my) * size + mx;
    errors[mi] = std::max(errors[mi], err);
    if (i < num_parents) {
      // Children's midpoints (only when the children are themselves parents).
      const size_t l = size_t((ay + cy) >> 1) * size + ((ax + cx) >> 1);
      const size_t r = size_t((by + cy) >> 1) * size + ((bx + cx) >> 1);
      errors[mi] = std::max({errors[mi], errors[l], errors[r]});
    }
    if (++reported % (1 << 18) == 0)
      report_progress(progress, "mesh", double(reported) / double(num_triangles) * 0.9, "errors");
  }

  Mesh m;
  VertexMap vm(h, m);
  const float limit = float(max_error_m);
  // Explicit stack instead of recursion: (a, b, c) with the right angle at c.
  struct Tri {
    int ax, ay, bx, by, cx, cy;
  };
  std::vector<Tri> stack{{0, 0, tile, tile, tile, 0}, {tile, tile, 0, 0, 0, tile}};
  while (!stack.empty()) {
    const Tri t = stack.back();
    stack.pop_back();
    const int mx = (t.ax + t.bx) >> 1, my = (t.ay + t.by) >> 1;
    if (std::abs(t.ax - t.cx) + std::abs(t.ay - t.cy) > 1 && errors[size_t(my) * size + mx] > limit) {
      stack.push_back({t.cx, t.cy, t.ax, t.ay, mx, my});
      stack.push_back({t.bx, t.by, t.cx, t.cy, mx, my});
      continue;
    }
    if (!valid(t.ax, t.ay) || !valid(t.bx, t.by) || !valid(t.cx, t.cy)) continue;
    uint32_t a = vm.get(t.ax, t.ay), b = vm.get(t.bx, t.by), c = vm.get(t.cx, t.cy);
    // Counter-clockwise seen from +Y (X east, Z south) means clockwise in (x, row) coordinates.
    const long cross = long(t.bx - t.ax) * (t.cy - t.ay) - long(t.by - t.ay) * (t.cx - t.ax);
    if (cross > 0) std::swap(b, c);
    m.indices.insert(m.indices.end(), {a, b, c});
  }
  if (m.indices.empty()) fail("mesh", "no valid triangle to write");
  report_progress(progress, "mesh", 1.0, "triangles");
  return m;
}

/// Unit vertex normals: area-weighted sums of the adjacent faces' normals (smooth shading in
/// viewers; without normals glTF viewers must shade flat facets).
std::vector<float> vertex_normals(const Mesh& m) {
  std::vector<double> acc(m.positions.size(), 0.0);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(m.positions[3 * b + k]) - m.positions[3 * a + k];
      v[k] = double(m.positions[3 * c + k]) - m.positions[3 * a + k];
    }
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    for (uint32_t i : {a, b, c})
      for (int k = 0; k < 3; ++k) acc[3 * i + k] += n[k];
  }
  std::vector<float> out(acc.size());
  for (size_t i = 0; i < acc.size(); i += 3) {
    const double len = std::sqrt(acc[i] * acc[i] + acc[i + 1] * acc[i + 1] + acc[i + 2] * acc[i + 2]);
    for (int k = 0; k < 3; ++k) out[i + k] = len > 0 ? float(acc[i + k] / len) : (k == 1 ? 1.f : 0.f);
  }
  return out;
}

namespace {

void write_obj(const Mesh& m, const std::string& path, const Metadata& meta) {
  write_atomically(path, [&](const std::string& tmp) {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) fail("mesh", "cannot write {}: {}", path, std::strerror(errno));
    std::string buf;
    buf.reserve(1 << 20);
    auto flush = [&] {
      if (std::fwrite(buf.data(), 1, buf.size(), f) != buf.size()) {
        const int err = errno;
        std::fclose(f);
        fail("mesh", "writing {} failed: {}", path, std::strerror(err));
      }
      buf.clear();
    };
    buf += fmt::format("# terracl heightfield mesh: metres, Y up, X east, Z south\n# {} vertices, {} triangles\n",
                       m.vertex_count(), m.triangle_count());
    for (const auto& [k, v] : meta) {  // provenance as comments, one line each
      std::string line = v;
      std::replace(line.begin(), line.end(), '\n', ' ');
      buf += fmt::format("# {} = {}\n", k, line);
    }
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      fmt::format_to(std::back_inserter(buf), "v {} {} {}\n", m.positions[3 * v], m.positions[3 * v + 1],
                     m.positions[3 * v + 2]);
      if (buf.size() > (1 << 20)) flush();
    }
    const std::vector<float> normals = vertex_normals(m);
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      fmt::format_to(std::back_inserter(buf), "vn {} {} {}\n", normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]);
      if (buf.size() > (1 << 20)) flush();
    }
    // OBJ's texture v points up (OpenGL), glTF's down: flip.
    const bool uv = m.texcoords.size() == 2 * m.vertex_count();
    for (size_t v = 0; uv && v < m.vertex_count(); ++v) {
      fmt::format_to(std::back_inserter(buf), "vt {} {}\n", m.texcoords[2 * v], 1.0f - m.texcoords[2 * v + 1]);
      if (buf.size() > (1 << 20)) flush();
    }
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t a = m.indices[3 * t] + 1, b = m.indices[3 * t + 1] + 1, c = m.indices[3 * t + 2] + 1;
      if (uv)
        fmt::format_to(std::back_inserter(buf), "f {}/{}/{} {}/{}/{} {}/{}/{}\n", a, a, a, b, b, b, c, c, c);
      else
        fmt::format_to(std::back_inserter(buf), "f {}//{} {}//{} {}//{}\n", a, a, b, b, c, c);
      if (buf.size() > (1 << 20)) flush();
    }
    flush();
    // fflush first: its errno says why (a full disk), fclose's may not.
    const bool flushed = std::fflush(f) == 0;
    const int err = errno;
    if (std::fclose(f) != 0 || !flushed)
      fail("mesh", "writing {} failed: {}", path, std::strerror(flushed ? errno : err));
  });
}

}  // namespace

std::string placement_json(const Heightfield& h) {
  const Georef& g = h.georef;
  nlohmann::json j;
  j["format"] = "terracl-mesh-placement";
  j["version"] = 1;
  j["axes"] = "glTF: X = east, Y = up, Z = south, metres; OBJ the same";
  j["grid"] = {{"width", h.width}, {"height", h.height}};
  j["cell_size_m"] = {g.cell_x, g.cell_y};
  j["z_scale"] = 1.0;  // vertex Y is the elevation in metres, not exaggerated
  j["vertical_units"] = g.vertical_units;
  j["texcoord"] = "TEXCOORD_0: u = (column + 0.5) / width, v = (row + 0.5) / height (v down); a picture of the "
                  "raster at its own size drapes pixel on cell";
  if (g.has_geotransform) {
    const auto& t = g.geotransform;
    // Vertex X = Z = 0 is the centre of cell (0, 0); the geotransform addresses cell corners.
    j["origin"] = {{"x", t[0] + 0.5 * t[1] + 0.5 * t[2]}, {"y", t[3] + 0.5 * t[4] + 0.5 * t[5]}, {"z", 0.0},
                   {"meaning", "map coordinates (CRS units) of the vertex at X = Z = 0, the north-west cell centre; "
                               "elevation 0 at Y = 0"}};
    j["geotransform"] = t;
    j["cell_size_crs"] = {t[1], t[5]};
  } else {
    j["origin"] = nullptr;
  }
  j["geographic"] = g.geographic;
  if (g.geographic)
    j["note"] = "the CRS is in degrees: X and Z use the metric cell size at the raster's centre latitude, so the "
                "mesh is a local tangent-plane approximation";
  j["crs_wkt"] = g.crs_wkt.empty() ? nlohmann::json(nullptr) : nlohmann::json(g.crs_wkt);
  // The CRS's own authority code is its last EPSG AUTHORITY (WKT1) / ID (WKT2) entry.
  nlohmann::json epsg = nullptr;
  static const std::regex code(R"re((?:AUTHORITY|ID)\[\s*"EPSG"\s*,\s*"?(\d+)"?\s*\])re");
  for (auto it = std::sregex_iterator(g.crs_wkt.begin(), g.crs_wkt.end(), code); it != std::sregex_iterator(); ++it)
    epsg = std::stoi((*it)[1].str());
  j["epsg"] = epsg;
  return j.dump();
}

namespace {

struct ImportHints {
  double z_scale, xy_cm[2], location_z_cm, size_m[3];
  bool square;
};

ImportHints import_hints(const Heightfield& h, double zmin, double zmax) {
  ImportHints r{};
  const double range = std::max(0.0, zmax - zmin);
  // Unreal: world Z (cm) = (code - 32768) * ZScale / 128 + LocationZ.
  r.z_scale = range * 100.0 * 128.0 / 65535.0;
  r.location_z_cm = zmin * 100.0 + 32768.0 * r.z_scale / 128.0;
  r.xy_cm[0] = h.georef.cell_x * 100.0;
  r.xy_cm[1] = h.georef.cell_y * 100.0;
  r.size_m[0] = (h.width - 1) * h.georef.cell_x;
  r.size_m[1] = range;
  r.size_m[2] = (h.height - 1) * h.georef.cell_y;
  r.square = std::abs(h.georef.cell_x - h.georef.cell_y) <= 0.01 * std::max(h.georef.cell_x, h.georef.cell_y);
  return r;
}

}  // namespace

std::string heightmap_import_json(const Heightfield& h, double zmin, double zmax) {
  const ImportHints r = import_hints(h, zmin, zmax);
  nlohmann::json j;
  j["unreal"] = {{"scale", {r.xy_cm[0], r.xy_cm[1], r.z_scale}},
                 {"location_z_cm", r.location_z_cm},
                 {"meaning", "Landscape import: Scale X, Y, Z and Location Z; Z scale 100 spans 512 m"}};
  j["unity"] = {{"terrain_size_m", {r.size_m[0], r.size_m[1], r.size_m[2]}},
                {"meaning", "Terrain width, height (vertical range), length; the terrain's base at zmin"}};
  j["square_cells"] = r.square;
  if (!r.square)
    j["warning"] = fmt::format("cells are {:.2f} x {:.2f} m, not square; engines stretch them to squares (resample first, "
                               "e.g. gdalwarp -tr)",
                               h.georef.cell_x, h.georef.cell_y);
  return j.dump();
}

std::string heightmap_import_summary(const Heightfield& h, double zmin, double zmax) {
  const ImportHints r = import_hints(h, zmin, zmax);
  std::string s = fmt::format("Unreal import: scale X {:.4g} Y {:.4g} Z {:.6g}, location Z {:.6g} cm; Unity terrain "
                              "size {:.6g} x {:.6g} x {:.6g} m\n",
                              r.xy_cm[0], r.xy_cm[1], r.z_scale, r.location_z_cm, r.size_m[0], r.size_m[1], r.size_m[2]);
  if (!r.square)
    s += fmt::format("warning: cells are {:.2f} x {:.2f} m, not square (a geographic DEM?); engines stretch them to "
                     "squares: resample to square cells first (gdalwarp -tr D D)\n",
                     h.georef.cell_x, h.georef.cell_y);
  return s;
}

void write_mesh(const Mesh& m, const std::string& path, const Metadata& meta, const Heightfield* grid) {
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".obj" && ext != ".glb" && ext != ".gltf")
    fail("mesh", "{}: unknown mesh format '{}' (expected .glb, .gltf or .obj)", path, ext);
  std::string placement;
  if (grid) {
    nlohmann::json j = nlohmann::json::parse(placement_json(*grid));
    j["mesh"] = {{"vertices", m.vertex_count()},
                 {"triangles", m.triangle_count()},
                 {"vertex_share_of_cells", double(m.vertex_count()) / double(grid->size())}};
    placement = j.dump();
  }
  if (ext == ".obj")
    write_obj(m, path, meta);
  else
    write_gltf(m, path, ext == ".glb", meta, placement);
  // The sidecar after the mesh: a sidecar never describes a mesh that failed to write.
  if (grid) write_text_file_atomic(path + ".json", nlohmann::json::parse(placement).dump(2) + "\n");
}

}  // namespace terracl::mesh
