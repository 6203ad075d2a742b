// SPDX-License-Identifier: Apache-2.0
// Sketch extraction and the metrics / sketch commands as a user runs them.
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include "test_helpers.hpp"

using namespace terracl;
using namespace terracl::analysis;
using nlohmann::json;

namespace {

/// A V-shaped valley along column 20 falling south, with a Gaussian hill on its east flank.
Heightfield valley_with_hill() {
  Heightfield h(41, 41);
  h.georef.cell_x = h.georef.cell_y = 10;
  for (int y = 0; y < 41; ++y)
    for (int x = 0; x < 41; ++x)
      h.at(x, y) = float(500 + 8.0 * std::abs(x - 20) - 2.0 * y +
                         150.0 * std::exp(-((x - 31) * (x - 31) + (y - 15) * (y - 15)) / 18.0));
  return h;
}

json read_json(const std::string& path) {
  std::ifstream f(path);
  return json::parse(f);
}

}  // namespace

TEST(AnalysisSketch, ValleyRiverAndHillPeak) {
  const Heightfield h = valley_with_hill();
  SketchOptions o;
  o.window = 9;
  o.prominence_m = 50;
  o.simplify_cells = 0;
  const Sketch s = extract_sketch(h, o);
  // The main river runs down column 20 to the south border and drains most of the grid.
  const Sketch::Line* main = nullptr;
  for (const auto& l : s.rivers)
    if (!main || l.drainage_area_m2 > main->drainage_area_m2) main = &l;
  ASSERT_NE(main, nullptr);
  EXPECT_EQ(main->points.back().y, 40.0);
  EXPECT_EQ(main->points.back().x, 20.0);
  EXPECT_GT(main->drainage_area_m2, 0.3 * h.size() * 100.0);
  // On the valley floor; the hill on the east flank pulls the sub-cell floor a little west.
  for (const auto& p : main->points) EXPECT_NEAR(p.x, 20.0, 0.25);
  for (size_t k = 1; k < main->points.size(); ++k) EXPECT_LT(main->points[k].z, main->points[k - 1].z);  // downstream
  // Exactly one peak, on the hill's top, and its square in the blue channel.
  ASSERT_EQ(s.peaks.size(), 1u);
  EXPECT_EQ(s.peaks[0].p.x, 31.0);
  EXPECT_EQ(s.peaks[0].p.y, 15.0);
  EXPECT_GT(s.peaks[0].relief_m, 50.0);
  EXPECT_GT(s.rgb[3 * (15 * 41 + 31) + 2], 0);
  EXPECT_EQ(s.rgb[3 * (15 * 41 + 31 - 10) + 2], 0);  // outside the 15-cell square
  // The river cells are green, the ridge network red, and they do not overlap on the valley floor.
  EXPECT_EQ(s.rgb[3 * (30 * 41 + 20) + 1], 255);
  EXPECT_EQ(s.rgb[3 * (30 * 41 + 20) + 0], 0);
  EXPECT_FALSE(s.ridges.empty());
  EXPECT_TRUE(s.basins.empty());  // the valley drains: no closed low

  const json j = sketch_to_json(s, h);
  EXPECT_EQ(j["format"], "terracl-sketch");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["rivers"].size(), s.rivers.size());
  EXPECT_EQ(j["peaks"][0]["x"], 31.0);
  EXPECT_EQ(j["rivers"][0]["points"][0].size(), 3u);

  // Simplification keeps the end points and drops the collinear ones.
  o.simplify_cells = 0.5;
  const Sketch simple = extract_sketch(h, o);
  size_t before = 0, after = 0;
  for (const auto& l : s.rivers) before += l.points.size();
  for (const auto& l : simple.rivers) after += l.points.size();
  EXPECT_LT(after, before);
  EXPECT_THROW(extract_sketch(h, SketchOptions{0.002, 0.002, 8, 1}), Error);
}

namespace {

/// Share of the polyline length (in cells) on segments at exactly 0, 45, 90 or 135 degrees: D8's
/// eight directions. Natural ridges and rivers take any direction.
double share_at_d8_angles(const std::vector<Sketch::Line>& lines, int w, int h) {
  double total = 0, d8 = 0;
  for (const auto& l : lines)
    for (size_t k = 1; k < l.points.size(); ++k) {
      const auto &a = l.points[k - 1], &b = l.points[k];
      // Lines running along the raster's edge are at 0/90 deg by construction: not counted.
      const bool edge = (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == w - 1 && b.x == w - 1) ||
                        (a.y == h - 1 && b.y == h - 1);
      if (edge) continue;
      const double dx = b.x - a.x, dy = b.y - a.y;
      const double len = std::hypot(dx, dy);
      total += len;
      if (std::abs(dx) < 1e-9 || std::abs(dy) < 1e-9 || std::abs(std::abs(dx) - std::abs(dy)) < 1e-9) d8 += len;
    }
  return total > 0 ? d8 / total : 0.0;
}

}  // namespace

// Issue 15: ridge lines showed long straight D8 runs at 0/45 deg. On a real DEM the traced lines
// must take natural directions; the raw D8 paths (line_smooth 0, the old behaviour) do not.
TEST(AnalysisSketch, LinesHaveNoD8StaircaseOnARealDem) {
  const Heightfield h = read_heightfield(test::data_path("crops/presidential_utm30_192.tif"));
  SketchOptions raw;
  raw.line_smooth_cells = 0;
  const Sketch old_way = extract_sketch(h, raw);
  const Sketch s = extract_sketch(h, SketchOptions{});
  const double old_ridges = share_at_d8_angles(old_way.ridges, h.width, h.height), old_rivers = share_at_d8_angles(old_way.rivers, h.width, h.height);
  const double ridges = share_at_d8_angles(s.ridges, h.width, h.height), rivers = share_at_d8_angles(s.rivers, h.width, h.height);
  std::printf("length at D8 angles: ridges %.1f %% -> %.1f %%, rivers %.1f %% -> %.1f %%\n", 100 * old_ridges,
              100 * ridges, 100 * old_rivers, 100 * rivers);
  ASSERT_FALSE(s.ridges.empty());
  ASSERT_FALSE(s.rivers.empty());
  // Lines of more than two points are re-traced as streamlines: none of their length is at a D8
  // angle. What remains is in two-point lines, one D8 step between two confluences (or a head and a
  // confluence), whose ends are fixed cell centres.
  for (const auto* set : {&s.rivers, &s.ridges}) {
    std::vector<Sketch::Line> two, longer;
    for (const auto& l : *set) (l.points.size() <= 2 ? two : longer).push_back(l);
    const double share_longer = share_at_d8_angles(longer, h.width, h.height);
    std::printf("%s: %zu two-point lines (%.1f %% at D8 angles), %zu longer lines (%.1f %%)\n",
                set == &s.rivers ? "rivers" : "ridges", two.size(), 100 * share_at_d8_angles(two, h.width, h.height),
                longer.size(), 100 * share_longer);
    EXPECT_LT(share_longer, 0.02);
  }
  EXPECT_GT(old_ridges, 0.6);  // the artefact is real on this DEM
  EXPECT_GT(old_rivers, 0.6);
  // What stays at D8 angles are lines with no trough across them (planar slopes, filled flats),
  // straight between their two end cells.
  EXPECT_LT(ridges, 0.25);
  EXPECT_LT(rivers, 0.2);
  EXPECT_LT(ridges, 0.5 * old_ridges);
  EXPECT_LT(rivers, 0.5 * old_rivers);
  // Smoothing moves the lines by less than a couple of cells and keeps their ends (confluences).
  ASSERT_EQ(s.ridges.size(), old_way.ridges.size());
  for (size_t i = 0; i < s.ridges.size(); ++i) {
    EXPECT_EQ(s.ridges[i].points.front().x, old_way.ridges[i].points.front().x);
    EXPECT_EQ(s.ridges[i].points.back().y, old_way.ridges[i].points.back().y);
  }
  // The picture shows the smoothed lines: as many ridge pixels as before, give or take.
  size_t px_old = 0, px_new = 0;
  for (size_t i = 0; i < h.size(); ++i) px_old += old_way.rgb[3 * i] > 0, px_new += s.rgb[3 * i] > 0;
  EXPECT_NEAR(double(px_new), double(px_old), 0.25 * px_old);
  SketchOptions bad;
  bad.line_smooth_cells = -1;
  EXPECT_THROW(extract_sketch(h, bad), Error);
}

// A smooth valley whose axis runs at 17 deg (a direction D8 does not have), falling along the axis,
// with planar-ish flanks: the true river direction is known everywhere. The main river must run at
// 17 deg and the network must have next to none of its length at exactly 0/45/90/135 deg; the raw
// D8 paths have most of it there.
TEST(AnalysisSketch, RiversFollowAValleyAtAnOddAngle) {
  const int n = 97;
  const double theta = 17.0 * M_PI / 180.0, ux = std::cos(theta), uy = std::sin(theta);
  Heightfield h(n, n);
  h.georef.cell_x = h.georef.cell_y = 10;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double dx = x - 48.0, dy = y - 48.0;
      const double along = dx * ux + dy * uy, across = -dx * uy + dy * ux;
      h.at(x, y) = float(1000.0 - 2.0 * along + 8.0 * std::sqrt(across * across + 4.0));
    }
  // Only the axis is a river: the flanks' parallel flow lines (under 70 cells) stay below it.
  SketchOptions opt;
  opt.river_fraction = 0.03;
  SketchOptions raw = opt;
  raw.line_smooth_cells = 0;
  const Sketch old_way = extract_sketch(h, raw), s = extract_sketch(h, opt);
  ASSERT_FALSE(s.rivers.empty());
  const auto main = std::max_element(s.rivers.begin(), s.rivers.end(), [](const auto& a, const auto& b) {
    return a.drainage_area_m2 < b.drainage_area_m2;
  });
  // Length-weighted angle error of the main river against the axis.
  double len = 0, err = 0;
  for (size_t k = 1; k < main->points.size(); ++k) {
    const auto &a = main->points[k - 1], &b = main->points[k];
    const double l = std::hypot(b.x - a.x, b.y - a.y);
    double d = std::atan2(b.y - a.y, b.x - a.x) - theta;
    d = std::remainder(d, M_PI);  // a line's direction, either way along it
    len += l;
    err += l * std::abs(d);
  }
  ASSERT_GT(len, 40.0) << "the main river must cross most of the grid";
  const double err_deg = err / len * 180.0 / M_PI;
  const double share = share_at_d8_angles(s.rivers, n, n), share_raw = share_at_d8_angles(old_way.rivers, n, n);
  std::printf("17-deg valley: main river mean angle error %.2f deg over %.0f cells; river length at D8 angles "
              "%.1f %% (raw D8 %.1f %%)\n",
              err_deg, len, 100 * share, 100 * share_raw);
  EXPECT_GT(share_raw, 0.5);  // the artefact is real here
  EXPECT_LT(share, 0.05);
  EXPECT_LT(err_deg, 2.0);
}

TEST(AnalysisCli, MetricsPrintsAndWritesJsonReport) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/frontrange_64.asc");
  const auto r = test::run_cli("-q metrics " + in + " --json " + tmp.path("m.json"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("b-bar"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("hypsometric integral"), std::string::npos);
  const json m = read_json(tmp.path("m.json"));
  for (const char* key :
       {"slope_deg", "laplacian_per_m", "spectral_slope", "hypsometric_integral", "fill", "breach", "drainage"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_EQ(m["drainage"]["outflow_cells"].get<double>(), 64.0 * 64.0);
  EXPECT_GE(m["breach"]["b_bar_m"].get<double>(), 0.0);
  EXPECT_TRUE(m.contains("provenance"));
  const auto missing = test::run_cli("-q metrics " + tmp.path("nope.tif"));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.out.find("nope.tif"), std::string::npos) << missing.out;
}

TEST(AnalysisCli, SketchWritesPictureAndPolylines) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const auto r = test::run_cli("-q sketch " + in + " -o " + tmp.path("s.png") + " --json " + tmp.path("s.json") +
                               " --smooth 1 --window 9");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  auto img = OIIO::ImageInput::open(tmp.path("s.png"));
  ASSERT_TRUE(img);
  EXPECT_EQ(img->spec().width, 128);
  EXPECT_EQ(img->spec().height, 96);
  EXPECT_EQ(img->spec().nchannels, 3);
  const json j = read_json(tmp.path("s.json"));
  EXPECT_EQ(j["format"], "terracl-sketch");
  EXPECT_GT(j["rivers"].size(), 0u);
  EXPECT_GT(j["ridges"].size(), 0u);
  for (const auto& l : j["rivers"])
    for (const auto& p : l["points"]) {
      ASSERT_GE(p[0].get<double>(), 0);
      ASSERT_LT(p[0].get<double>(), 128);
      ASSERT_GE(p[1].get<double>(), 0);
      ASSERT_LT(p[1].get<double>(), 96);
    }
  const auto bad = test::run_cli("-q sketch " + in + " -o " + tmp.path("t.png") + " --window 1");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("window"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("t.png")));
}

TEST(AnalysisCli, FillBreachAndDrainageStages) {
  test::TempDir tmp;
  const std::string in = test::data_path("crops/frontrange_64.asc");
  const Heightfield h = read_heightfield(in);
  auto r = test::run_cli("-q breach " + in + " -o " + tmp.path("b.tif"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield b = read_heightfield(tmp.path("b.tif"));
  EXPECT_EQ(priority_flood_fill(b).cells_raised, 0u);  // drains everywhere
  EXPECT_DOUBLE_EQ(b.georef.cell_x, h.georef.cell_x);  // georeferencing kept
  r = test::run_cli("-q fill_depressions " + in + " -o " + tmp.path("f.tif") + " --epsilon");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield f = read_heightfield(tmp.path("f.tif"));
  EXPECT_EQ(f.z, priority_flood_fill(h, true).filled.z);
  r = test::run_cli("-q drainage " + in + " -o " + tmp.path("a.tif") + " --method dinf --units cells");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield a = read_heightfield(tmp.path("a.tif"));
  const DinfResult di = dinf_flow(h);
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a.z[i], di.cells[i], 1e-3 * di.cells[i]);
  r = test::run_cli("-q drainage " + in + " -o " + tmp.path("m2.tif"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield m2 = read_heightfield(tmp.path("m2.tif"));
  const D8Result d8 = d8_flow(h);
  for (size_t i = 0; i < m2.size(); ++i) ASSERT_NEAR(m2.z[i], d8.area_m2(i), 1e-6 * d8.area_m2(i));
  r = test::run_cli("-q drainage " + in + " -o " + tmp.path("x.tif") + " --method mfd");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("mfd"), std::string::npos) << r.out;
}

// Strahler order of the river segments: heads are 1, and at each confluence the segment that
// starts there has the largest order flowing in, plus one when two or more inflows share it
// (Strahler 1957). Segments meet at shared cell-centre end points (first point of the downstream
// segment = last point of each inflow).
TEST(AnalysisSketch, StrahlerOrderFollowsItsRuleAtEveryConfluence) {
  const Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  SketchOptions o;
  o.river_fraction = 0.003;
  const Sketch s = extract_sketch(h, o);
  auto key = [](const Sketch::Point& p) { return std::pair{std::lround(p.x * 4), std::lround(p.y * 4)}; };
  std::map<std::pair<long, long>, std::vector<int>> inflows;
  for (const auto& l : s.rivers) inflows[key(l.points.back())].push_back(l.strahler);
  int checked = 0, top = 0;
  for (const auto& l : s.rivers) {
    ASSERT_GE(l.strahler, 1);
    top = std::max(top, l.strahler);
    const auto it = inflows.find(key(l.points.front()));
    if (it == inflows.end()) continue;  // a head (or an end point moved by smoothing)
    const std::vector<int>& in = it->second;
    const int mx = *std::max_element(in.begin(), in.end());
    const int n_mx = int(std::count(in.begin(), in.end(), mx));
    EXPECT_EQ(l.strahler, mx + (n_mx >= 2 ? 1 : 0));
    ++checked;
  }
  EXPECT_GT(checked, 10) << "confluences found";
  EXPECT_GE(top, 3) << "a real DEM's network reaches order 3";
}
