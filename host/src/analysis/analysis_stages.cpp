// SPDX-License-Identifier: Apache-2.0
// Stage and benchmark registration for analysis, previews and export. `metrics`, `sketch`,
// `render` and `mesh` write their own files (option `file` / `json`) and pass the heightfield
// through unchanged, so they can sit anywhere in a pipeline; their CLI commands are hand-written
// (apps/cmd_analysis.cpp) because `-o` names the picture / mesh / report, not a heightfield.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <chrono>
#include <ctime>
#include <random>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/mesh.hpp>
#include <terracl/render.hpp>

#include "pipeline/builtin.hpp"

namespace terracl {

namespace {

void run_metrics(StageContext& c) {
  const json report = analysis::terrain_metrics(c.height(), c.progress);
  json out = report;
  out["provenance"] = c.provenance;
  if (c.has("json")) write_text_file_atomic(c.get<std::string>("json"), out.dump(2) + "\n");
}

void run_sketch(StageContext& c) {
  analysis::SketchOptions o;
  o.river_fraction = c.get<double>("river_fraction");
  o.ridge_fraction = c.get<double>("ridge_fraction");
  o.window = int(c.get<int64_t>("window"));
  o.prominence_m = c.has("prominence") ? c.get<double>("prominence") : -1.0;
  o.smooth_cells = c.get<double>("smooth");
  o.simplify_cells = c.get<double>("simplify");
  o.line_smooth_cells = c.get<double>("line_smooth");
  o.patch = int(c.get<int64_t>("patch"));
  const Heightfield& h = c.height();
  const analysis::Sketch s = analysis::extract_sketch(h, o, c.progress);
  render::Image img;
  img.width = s.width;
  img.height = s.height;
  img.pixels = s.rgb;
  render::write_image(img, c.get<std::string>("file"), c.provenance);
  if (c.has("json")) {
    const std::string out = c.get<std::string>("json");
    if (analysis::is_sketch_vector_path(out))
      analysis::write_sketch_vectors(s, h, out);
    else
      write_text_file_atomic(out, analysis::sketch_to_json(s, h).dump(1) + "\n");
  }
}

// A D8 pointer raster in a GIS's coding: ESRI (ArcGIS Flow Direction: 1 east, then clockwise
// doubling to 128 north-east) or GRASS (r.watershed's drainage: 1 north-east, counter-clockwise to
// 8 east). 0 where water leaves the grid (a border or nodata-side outlet), nodata where the
// elevation is nodata.
void write_d8_pointer(StageContext& c, bool esri) {
  Heightfield& h = c.height();
  if (c.get<std::string>("method") != "d8")
    throw UsageError("drainage", "product " + c.get<std::string>("product") + " is a D8 pointer raster; use method d8");
  const analysis::D8Result d8 = analysis::d8_flow(h, c.progress);
  Heightfield out = h;
  for (size_t i = 0; i < out.size(); ++i) {
    const uint8_t d = d8.dir[i];
    out.z[i] = d == analysis::kNoFlow ? NAN : d == analysis::kOutlet ? 0.0f : esri ? float(1u << d) : float(8 - d);
  }
  out.georef.vertical_units = "";
  out.metadata["terracl:quantity"] = esri ? "D8 flow direction (ESRI: 1 E, 2 SE, 4 S, 8 SW, 16 W, 32 NW, 64 N, 128 NE; 0 outlet)"
                                          : "D8 flow direction (GRASS: 1 NE, 2 N, 3 NW, 4 W, 5 SW, 6 S, 7 SE, 8 E; 0 outlet)";
  h = std::move(out);
}

// Pour points "X,Y[;X,Y...]" in the raster's map coordinates (its CRS; local metres from the
// south-west corner for a raster without georeferencing) to cell indices.
std::vector<std::pair<int, int>> pour_cells(const Heightfield& h, const std::string& text) {
  const Georef& g = h.georef;
  std::array<double, 6> gt = {0.0, g.cell_x, 0.0, g.cell_y * h.height, 0.0, -g.cell_y};
  if (g.has_geotransform) gt = g.geotransform;
  const double det = gt[1] * gt[5] - gt[2] * gt[4];
  std::vector<std::pair<int, int>> cells;
  auto to_cell = [&](double X, double Y) {
    const double dx = X - gt[0], dy = Y - gt[3];
    const double col = (gt[5] * dx - gt[2] * dy) / det, row = (-gt[4] * dx + gt[1] * dy) / det;
    const int x = int(std::floor(col)), y = int(std::floor(row));
    if (!(col >= 0 && row >= 0 && col < h.width && row < h.height))
      throw UsageError("watershed", fmt::format("points: {},{} lies outside the raster (cell {}, {} of {} x {})", X, Y,
                                                std::floor(col), std::floor(row), h.width, h.height));
    cells.push_back({x, y});
  };
  // A vector file (any OGR source) rather than coordinates.
  if (text.find(',') == std::string::npos && path_exists(text, true)) {
    for (const auto& p : analysis::read_pour_points(text, g)) to_cell(p[0], p[1]);
    return cells;
  }
  size_t at = 0;
  while (at <= text.size()) {
    const size_t end = std::min(text.find(';', at), text.size());
    const std::string item = text.substr(at, end - at);
    at = end + 1;
    if (item.find_first_not_of(" ") == std::string::npos) continue;
    double X = 0, Y = 0;
    char comma = 0, extra = 0;
    if (std::sscanf(item.c_str(), " %lf %c %lf %c", &X, &comma, &Y, &extra) != 3 || comma != ',' || !std::isfinite(X) ||
        !std::isfinite(Y))
      throw UsageError("watershed", fmt::format("points: '{}' is not X,Y (map coordinates of the raster's CRS; several "
                                                "separated by ';')", abbreviate(item, 40)));
    to_cell(X, Y);
  }
  if (cells.empty()) throw UsageError("watershed", "points: expected at least one X,Y");
  return cells;
}

// Watersheds of pour points on the D8 directions: cell i gets the 1-based number of the pour point
// it drains to, NaN when it drains elsewhere. A pour point upstream of another cuts its basin out
// of the other's (nested basins, as r.water.outlet / Watershed tools give them).
void run_watershed(StageContext& c) {
  Heightfield& h = c.height();
  std::vector<std::pair<int, int>> pours = pour_cells(h, c.get<std::string>("points"));
  const analysis::D8Result d8 = analysis::d8_flow(h, c.progress);
  const int w = h.width, H = h.height, snap = int(c.get<int64_t>("snap"));
  // Snapping: the cell of largest accumulation within `snap` cells (a point clicked beside the
  // river channel).
  for (auto& [px, py] : pours) {
    int bx = px, by = py;
    for (int y = std::max(0, py - snap); y <= std::min(H - 1, py + snap); ++y)
      for (int x = std::max(0, px - snap); x <= std::min(w - 1, px + snap); ++x)
        if (d8.cells[size_t(y) * w + x] > d8.cells[size_t(by) * w + bx]) bx = x, by = y;
    px = bx, py = by;
  }
  std::vector<int> label(h.size(), 0);
  for (size_t k = 0; k < pours.size(); ++k) {
    const size_t i = size_t(pours[k].second) * w + pours[k].first;
    if (d8.dir[i] == analysis::kNoFlow)
      throw UsageError("watershed", fmt::format("points: pour point {} is on a nodata cell", k + 1));
    label[i] = int(k + 1);
  }
  std::vector<size_t> stack;
  for (size_t k = 0; k < pours.size(); ++k) {
    const size_t start = size_t(pours[k].second) * w + pours[k].first;
    if (label[start] != int(k + 1)) continue;  // two points snapped to one cell: the first keeps it
    stack.push_back(start);
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      const int x = int(i % w), y = int(i / w);
      for (int d = 0; d < 8; ++d) {
        const int u = x - analysis::kDx[d], v = y - analysis::kDy[d];  // the neighbour that would flow here along d
        if (u < 0 || v < 0 || u >= w || v >= H) continue;
        const size_t j = size_t(v) * w + u;
        if (d8.dir[j] != d || label[j] != 0) continue;  // not a donor, or another pour point / done
        label[j] = int(k + 1);
        stack.push_back(j);
      }
    }
  }
  Heightfield out = h;
  for (size_t i = 0; i < out.size(); ++i) out.z[i] = label[i] ? float(label[i]) : NAN;
  out.georef.vertical_units = "";
  out.georef.nodata = -1.0;
  out.metadata["terracl:quantity"] = "watershed number (1-based, in the order of points; nodata: drains elsewhere)";
  h = std::move(out);
}

void run_drainage(StageContext& c) {
  if (const std::string p = c.get<std::string>("product"); p != "area") return write_d8_pointer(c, p == "d8_esri");
  Heightfield& h = c.height();
  const bool dinf = c.get<std::string>("method") == "dinf";
  const std::vector<double>* cells;
  double area = 1;
  analysis::D8Result d8;
  analysis::DinfResult di;
  // The epsilon fill in place of the stage's raster (its nodata cells stay nodata): the routing then
  // finds a surface that drains and takes it as it is, with no copy (8193^2: 268 MB less).
  const Progress routing = scaled_progress(c.progress, 0.5, 1.0);
  analysis::fill_for_routing(h, scaled_progress(c.progress, 0.0, 0.5));
  if (dinf) {
    di = analysis::dinf_flow(h, routing, false);  // the stage writes areas only
    cells = &di.cells;
    area = di.cell_area_m2;
  } else {
    d8 = analysis::d8_flow(h, routing);
    cells = &d8.cells;
    area = d8.cell_area_m2;
  }
  const bool as_cells = c.get<std::string>("units") == "cells";
  // In place: each cell's elevation is read once, for its nodata test, before its area replaces it.
  for (size_t i = 0; i < h.size(); ++i)
    h.z[i] = std::isnan(h.z[i]) ? NAN : float((*cells)[i] * (as_cells ? 1.0 : area));
  h.georef.vertical_units = as_cells ? "cells" : "m2";
  h.metadata["terracl:quantity"] = dinf ? "D-infinity drainage area" : "D8 drainage area";
}

}  // namespace

void register_analysis_stages(StageRegistry& r) {
  const auto H = DataKind::Heightfield;
  r.add({"metrics",
         "Realism statistics (slope, curvature, spectrum, hypsometry, drainage, fill and breach volumes) as a "
         "JSON report; passes the heightfield through.",
         H,
         H,
         {{"json", OptionType::OutputPath, nullptr, "", "JSON report to write", {}, true}},
         run_metrics,
         false});
  r.add({"sketch",
         "Extract rivers, ridges, peaks and basins as a sketch picture (R ridges, G rivers, B peak/basin "
         "elevation squares) and polylines JSON; passes the heightfield through.",
         H,
         H,
         {{"file", OptionType::OutputPath, nullptr, "", "Sketch picture (.png)", {}, true},
          {"json",
           OptionType::OutputPath,
           nullptr,
           "",
           "Polylines/points: .json (terracl's, pixel coordinates; docs/analysis.md) or a GIS vector file in map "
           "coordinates (.geojson, .gpkg, .kml)",
           {},
           false},
          {"river_fraction",
           OptionType::Float,
           0.002,
           "",
           "River threshold: D8 accumulation as a fraction of the cells",
           {},
           false},
          {"ridge_fraction",
           OptionType::Float,
           0.002,
           "",
           "Ridge threshold on the inverted terrain, as a fraction of the cells",
           {},
           false},
          {"window", OptionType::Int, 15, "cells", "Peak/basin max/min filter size", {}, false},
          {"prominence",
           OptionType::Float,
           nullptr,
           "m",
           "Peak/basin relief threshold in the window (default 10 % of the relief)",
           {},
           false},
          {"smooth",
           OptionType::Float,
           0.0,
           "cells",
           "Gaussian blur sigma before extraction (coarser sketches)",
           {},
           false},
          {"simplify", OptionType::Float, 0.5, "cells", "Douglas-Peucker tolerance of the polylines", {}, false},
          {"line_smooth",
           OptionType::Float,
           3.0,
           "cells",
           "Gaussian sigma along the traced lines, against D8's 0/45-degree staircase (0: raw D8 paths)",
           {},
           false},
          {"patch", OptionType::Int, 15, "cells", "Size of the peak/basin squares in the picture", {}, false}},
         run_sketch,
         false});
  r.add(render_stage_info());  // host/src/render/render_stage.cpp
  r.add(mesh_stage_info());  // host/src/mesh/mesh_stage.cpp
  r.add({"fill_depressions",
         "Priority-Flood depression filling (Barnes et al. 2014); --epsilon gives every flat a drainage gradient.",
         H,
         H,
         {{"epsilon",
           OptionType::Bool,
           false,
           "",
           "Raise flats by the smallest float steps so that every cell drains",
           {},
           false}},
         [](StageContext& c) {
           Heightfield& h = c.height();
           h = analysis::priority_flood_fill(std::move(h), c.get<bool>("epsilon"), c.progress).filled;
         }});
  r.add({"breach",
         "Complete depression breaching (Lindsay 2016): carve channels from every pit to its outlet.",
         H,
         H,
         {{"raise_pits",
           OptionType::Bool,
           true,
           "",
           "Raise single-cell pits to their lowest neighbour first",
           {},
           false}},
         [](StageContext& c) {
           Heightfield& h = c.height();
           h = analysis::breach_depressions(h, c.get<bool>("raise_pits"), c.progress).breached;
         }});
  r.add({"drainage",
         "Replace the heightfield by its drainage area (D8 or D-infinity, flats resolved), in m2 or cells, or by "
         "its D8 flow directions in ESRI or GRASS coding.",
         H,
         H,
         {{"method", OptionType::Enum, "d8", "", "Flow routing", {"d8", "dinf"}, false},
          {"units", OptionType::Enum, "m2", "", "Drainage area in square metres or in cells", {"m2", "cells"}, false},
          {"product",
           OptionType::Enum,
           "area",
           "",
           "What to write: the drainage area, or the D8 flow direction raster in ESRI (1..128) or GRASS (1..8) "
           "coding (0: flows off the grid)",
           {"area", "d8_esri", "d8_grass"},
           false}},
         run_drainage});
  r.add({"watershed",
         "Replace the heightfield by the watersheds of pour points on the D8 directions: each cell the number "
         "(1, 2, ...) of the point it drains to, nodata elsewhere; nested points cut their basin out.",
         H,
         H,
         {{"points",
           OptionType::String,
           nullptr,
           "",
           "Pour points X,Y in the raster's map coordinates (local metres for a raster without georeferencing), "
           "several separated by ';', or a vector file of points (GeoJSON, GeoPackage, Shapefile; transformed to the "
           "raster's CRS)",
           {},
           true},
          {"snap", OptionType::Int, int64_t(0), "cells", "Move each point to the largest accumulation within this many cells", {}, false}},
         run_watershed});
}

namespace {

/// Deterministic fBm value noise with many closed depressions (a hard case for fill and breach).
Heightfield bench_terrain(int n) {
  Heightfield h(n, n, 0.f);
  h.georef.cell_x = h.georef.cell_y = 30.0;
  std::mt19937 rng(7);
  double amp = 400, total = 0;
  for (int period = n / 2; period >= 2; period /= 2) {
    const int g = n / period + 2;
    std::vector<float> lattice(size_t(g) * g);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    for (float& v : lattice) v = u(rng);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double fx = double(x) / period, fy = double(y) / period;
        const int ix = int(fx), iy = int(fy);
        const double tx = fx - ix, ty = fy - iy;
        const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
        const double a = lattice[size_t(iy) * g + ix], b = lattice[size_t(iy) * g + ix + 1];
        const double c = lattice[size_t(iy + 1) * g + ix], d = lattice[size_t(iy + 1) * g + ix + 1];
        h.at(x, y) += float(amp * ((a + (b - a) * sx) * (1 - sy) + (c + (d - c) * sx) * sy));
      }
    total += amp;
    amp *= 0.5;
  }
  for (float& v : h.z) v += float(total);
  return h;
}

}  // namespace

void register_analysis_benches(BenchRegistry& r) {
  r.add({"analysis",
         "Fill, epsilon fill, breach, D8 and D-inf accumulation, hillshade, mesh on an N x N grid (median "
         "seconds); --set dem=FILE uses the top-left N x N of a real DEM",
         [](const BenchArgs& a) {
           Heightfield h;
           std::string source = "synthetic fBm value noise, 30 m cells";
           if (a.extra.contains("dem")) {
             const std::string path = a.extra["dem"].get<std::string>();
             Heightfield full = read_heightfield(path);
             const int n = std::min({a.size, full.width, full.height});
             h = Heightfield(n, n);
             h.georef = full.georef;
             for (int y = 0; y < n; ++y)
               for (int x = 0; x < n; ++x) h.at(x, y) = full.at(x, y);
             source = fmt::format("{} (top-left {} x {})", path, n, n);
           } else {
             h = bench_terrain(a.size);
           }
           fmt::print("analysis bench: {} x {} cells, {}; median of {} runs\n", h.width, h.height, source, a.repeats);
           // Wall-clock median and the process CPU time of the same runs (the CPU time is less
           // sensitive to other processes on a shared machine).
           auto time = [&](const char* what, int repeats, auto&& f, auto&& note) {
             std::vector<double> wall;
             const std::clock_t c0 = std::clock();
             for (int r = 0; r < repeats; ++r) {
               const auto a = std::chrono::steady_clock::now();
               f();
               wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
             }
             const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC / repeats;
             std::sort(wall.begin(), wall.end());
             fmt::print("  {:<22} {:8.4f} s (cpu {:.4f} s)   {}\n", what, wall[wall.size() / 2], cpu, note());
           };
           const int n = a.repeats;
           analysis::FillResult f;
           time(
               "fill (Priority-Flood)", n, [&] { f = analysis::priority_flood_fill(h, false); },
               [&] { return fmt::format("volume {:.4g} m3, {} cells", f.volume_m3, f.cells_raised); });
           time(
               "fill epsilon", n, [&] { f = analysis::priority_flood_fill(h, true); }, [] { return std::string(); });
           analysis::BreachResult b;
           time(
               "breach (Lindsay)", n, [&] { b = analysis::breach_depressions(h); },
               [&] { return fmt::format("b {:.4g} m3, b-bar {:.4f} m", b.volume_m3, b.mean_depth_m); });
           analysis::D8Result d8;
           time(
               "D8 accumulation", n, [&] { d8 = analysis::d8_flow(h); },
               [&] {
                 return fmt::format("incl. epsilon fill; outflow {} of {} cells", d8.outflow_cells, d8.valid_cells);
               });
           analysis::DinfResult di;
           time(
               "D-inf accumulation", n, [&] { di = analysis::dinf_flow(h); },
               [&] { return fmt::format("outflow {:.8g}", di.outflow_cells); });
           time(
               "hillshade", n, [&] { (void)render::hillshade(h); }, [] { return std::string(); });
           mesh::Mesh m;
           time(
               "mesh simplify 1 m", n, [&] { m = mesh::triangulate_simplified(h, 1.0); },
               [&] {
                 return fmt::format("greedy insertion, {} triangles, {:.1f} % of the cells as vertices",
                                    m.triangle_count(), 100.0 * m.vertex_count() / h.size());
               });
           time(
               "mesh simplify 1 m RTIN", n, [&] { m = mesh::triangulate_rtin(h, 1.0); },
               [&] {
                 return fmt::format("{} triangles, {:.1f} % of the cells as vertices", m.triangle_count(),
                                    100.0 * m.vertex_count() / h.size());
               });
           time(
               "metrics (all)", std::max(1, n / 3), [&] { (void)analysis::terrain_metrics(h); },
               [] { return std::string(); });
         }});
}

}  // namespace terracl
