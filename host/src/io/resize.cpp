// SPDX-License-Identifier: Apache-2.0
// `resize` to a size or an engine preset (over the same extent, through warp), and the scale an
// engine needs to import a 16-bit heightmap at true size. Kept in the core build: the engine
// scale is recorded in every PNG16/RAW16 sidecar.
#include <terracl/error.hpp>
#include <terracl/warp.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace terracl {

// Here rather than in warp.cpp: option tables list the methods in the core build too (no GDAL).
const std::vector<std::string>& warp_resamplings() {
  static const std::vector<std::string> r = {"near", "bilinear", "cubic", "cubicspline", "lanczos", "average"};
  return r;
}

const std::vector<std::pair<std::string, int>>& engine_presets() {
  // Unreal: the recommended landscape sizes of the Landscape Technical Guide (whole sections of
  // 63/127/255 quads); Unity: terrain heightmap resolutions 2^n + 1.
  static const std::vector<std::pair<std::string, int>> presets = {
      {"unreal-505", 505},   {"unreal-1009", 1009}, {"unreal-2017", 2017}, {"unreal-4033", 4033},
      {"unreal-8129", 8129}, {"unity-513", 513},    {"unity-1025", 1025},  {"unity-2049", 2049},
      {"unity-4097", 4097}};
  return presets;
}

int engine_preset_size(const std::string& name, const std::string& stage) {
  std::vector<std::string> names;
  for (const auto& [n, size] : engine_presets()) {
    if (n == name) return size;
    names.push_back(n);
  }
  fail(stage, "unknown preset '{}'; expected one of {}", name, fmt::join(names, ", "));
}

Heightfield resize(const Heightfield& h, int width, int height, const std::string& resampling,
                   const Progress& progress, const std::string& stage) {
  if (width < 2 || height < 2 || width > 65536 || height > 65536)
    fail(stage, "size {} x {} is out of range; width and height must be in 2..65536", width, height);
  WarpOptions o;
  o.ts = std::array<int, 2>{width, height};
  o.resampling = resampling;
  return warp(h, o, progress, stage);
}

EngineScale engine_scale(double zmin, double zmax, bool reserve_nodata, double cell_x, double cell_y) {
  // Unreal: world Z (cm) = Location Z + (code - 32768) / 128 * Scale Z, so Scale Z 100 spans
  // 65535 / 128 = 512 m; one code of ours is range / (65535 - lo) m.
  const double lo = reserve_nodata ? 1.0 : 0.0, range = zmax - zmin;
  const double per_code = range / (65535.0 - lo);
  EngineScale s{};
  s.unreal_z_scale = range > 0 ? 12800.0 * per_code : 100.0;  // any scale draws a flat map
  s.unreal_x_scale = cell_x * 100.0;
  s.unreal_y_scale = cell_y * 100.0;
  s.unreal_z_location = 100.0 * (zmin + (32768.0 - lo) * per_code);
  // Unity: elevation = Position Y + code / 65535 * Terrain Height.
  s.unity_height = per_code * 65535.0;
  s.unity_position_y = zmin - lo * per_code;
  return s;
}

std::vector<std::pair<std::string, double>> engine_scale_entries(const EngineScale& s) {
  return {{"unreal_z_scale", s.unreal_z_scale},
          {"unreal_x_scale", s.unreal_x_scale},
          {"unreal_y_scale", s.unreal_y_scale},
          {"unreal_z_location_cm", s.unreal_z_location},
          {"unity_terrain_height_m", s.unity_height},
          {"unity_position_y_m", s.unity_position_y}};
}

std::string square_cell_advice(const Heightfield& h) {
  const Georef& g = h.georef;
  if (g.geographic)
    return fmt::format("cells are {:.3f} x {:.3f} m (a geographic CRS); engines take square cells: "
                       "terracl warp IN -o OUT --t-srs EPSG:<UTM zone> --tr C C first",
                       g.cell_x, g.cell_y);
  return fmt::format("cells are {:.3f} x {:.3f} m: the size does not follow the extent's proportions ({:.0f} x {:.0f} m), "
                     "so engines stretch the terrain; crop to a square extent first (terracl warp IN -o OUT --projwin ...) "
                     "or resize with --size W H in proportion",
                     g.cell_x, g.cell_y, g.cell_x * h.width, g.cell_y * h.height);
}

EngineScale record_engine_scale(Heightfield& h) {
  double lo = INFINITY, hi = -INFINITY;
  for (float v : h.z)
    if (std::isfinite(v)) lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
  if (lo > hi) lo = hi = 0.0;
  const EngineScale s = engine_scale(lo, hi, h.count_nodata() > 0, h.georef.cell_x, h.georef.cell_y);
  for (const auto& [k, v] : engine_scale_entries(s)) h.metadata["engine:" + k] = fmt::format("{:.6f}", v);
  return s;
}

}  // namespace terracl
