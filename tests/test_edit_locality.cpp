// SPDX-License-Identifier: Apache-2.0
// Locality of edits on real DEMs: a crest on a crop of each bundled DEM changes the
// terrain near the crest only, and the same edit solved globally does not; map units, off-grid
// primitives, zero widths and sub-cell supports.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

using namespace terracl;
using json = nlohmann::json;

namespace {

// A w x h window of a raster starting at (x0, y0), with the geotransform moved to it.
Heightfield crop(const Heightfield& h, int x0, int y0, int w, int hh) {
  Heightfield c(w, hh);
  c.georef = h.georef;
  for (int y = 0; y < hh; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  auto& gt = c.georef.geotransform;
  gt[0] = h.georef.geotransform[0] + x0 * gt[1] + y0 * gt[2];
  gt[3] = h.georef.geotransform[3] + x0 * gt[4] + y0 * gt[5];
  return c;
}

Heightfield dem(const std::string& name, int x0, int y0, int n) {
  Heightfield h = read_heightfield(test::data_path("dem/" + name));
  if (h.count_nodata()) fill_nodata_harmonic(h);
  return crop(h, x0, y0, n, n);
}

// Distance (metres) from cell (x, y) to the segment a-b given in cells.
double seg_dist(const Heightfield& h, int x, int y, std::array<double, 2> a, std::array<double, 2> b) {
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  const double px = x * cx, py = y * cy, ax = a[0] * cx, ay = a[1] * cy, ux = (b[0] - a[0]) * cx, uy = (b[1] - a[1]) * cy;
  const double t = std::clamp(((px - ax) * ux + (py - ay) * uy) / (ux * ux + uy * uy), 0.0, 1.0);
  return std::hypot(px - ax - t * ux, py - ay - t * uy);
}

struct CrestFigures {
  double far_median = 0, far_p99 = 0, crest_error = 0;
  size_t far_cells = 0, bit_exact_far = 0;
  double edge_change = 0;  // largest change of a changed cell next to an unchanged one
};

// A crest 300 m above the highest base cell along it, radius 8 cells; figures beyond 5 radii.
CrestFigures crest_figures(const Heightfield& base, const std::string& solve) {
  const int n = base.width;
  const std::array<double, 2> a{0.35 * n, 0.45 * n}, b{0.65 * n, 0.55 * n};
  const double radius_cells = 8, r = radius_cells * base.georef.cell_x;
  float top = -1e30f;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      if (seg_dist(base, x, y, a, b) < r) top = std::max(top, base.at(x, y));
  const double z = top + 300;
  json crest = {{"op", "crest"}, {"points", {{a[0], a[1]}, {b[0], b[1]}}}, {"elevation", z}, {"radius", radius_cells}};
  json script = {{"units", "cells"}, {"operations", {crest}}};
  if (!solve.empty()) script["solve"] = solve;
  EditSession s(test::device(), base);
  s.apply(script);
  const Heightfield& h = s.height();
  std::vector<double> far;
  CrestFigures f;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double d = seg_dist(base, x, y, a, b);
      if (d > 5 * r) {
        far.push_back(std::abs(double(h.at(x, y)) - base.at(x, y)));
        const float hv = h.at(x, y), bv = base.at(x, y);
        f.bit_exact_far += std::memcmp(&hv, &bv, sizeof(float)) == 0;
      }
      if (d < 0.5 * base.georef.cell_x) f.crest_error = std::max(f.crest_error, std::abs(double(h.at(x, y)) - z));
    }
  for (int y = 1; y + 1 < n; ++y)
    for (int x = 1; x + 1 < n; ++x) {
      auto same = [&](int a, int b) { return h.at(a, b) == base.at(a, b); };
      if (!same(x, y) && (same(x - 1, y) || same(x + 1, y) || same(x, y - 1) || same(x, y + 1)))
        f.edge_change = std::max(f.edge_change, std::abs(double(h.at(x, y)) - base.at(x, y)));
    }
  std::sort(far.begin(), far.end());
  f.far_cells = far.size();
  f.far_median = far[far.size() / 2];
  f.far_p99 = far[size_t(0.99 * double(far.size() - 1))];
  return f;
}

void expect_local(const Heightfield& base, const std::string& name) {
  const CrestFigures local = crest_figures(base, "");
  EXPECT_GT(local.far_cells, size_t(base.size() / 4)) << name;
  EXPECT_LE(local.far_median, 0.5) << name;
  EXPECT_LE(local.far_p99, 2.0) << name;
  EXPECT_LE(local.crest_error, 1.0) << name;
  EXPECT_EQ(local.bit_exact_far, local.far_cells) << name << ": cells beyond the falloff keep the base bit for bit";
  // The change reaches zero with zero slope (no crease at the region's edge): next to an unchanged
  // cell it is a fraction of a metre (an untapered harmonic fade leaves metres there).
  EXPECT_LE(local.edge_change, 0.5) << name;
  // The same crest solved globally (Neumann border, one hard curve) lifts the far terrain.
  const CrestFigures global = crest_figures(base, "global");
  // The figures quoted in docs/authoring.md.
  std::printf("%s: %zu cells beyond 5 radii; local: median %.3f m, p99 %.3f m, crest error %.3f m, edge change %.3f m; global: median %.1f m, "
              "p99 %.1f m\n",
              name.c_str(), local.far_cells, local.far_median, local.far_p99, local.crest_error, local.edge_change, global.far_median, global.far_p99);
  EXPECT_LE(global.crest_error, 1.0) << name;
  EXPECT_TRUE(global.far_median > 0.5 || global.far_p99 > 2.0)
      << name << ": global far median " << global.far_median << " p99 " << global.far_p99;
}

}  // namespace

TEST(EditLocality, CrestStaysLocalOnN44W072) {
  expect_local(dem("N44W072.hgt", 520, 220, 193), "N44W072");
}

TEST(EditLocality, CrestStaysLocalOnFrontRange) {
  expect_local(dem("frontrange_srtm3_758.asc", 300, 300, 193), "frontrange");
}

TEST(EditLocality, FlatBaseSolvesLocallyForLandformStrokesAndScriptsChoose) {
  EditSession flat(test::device(), *parse_flat_spec("flat:65x65@10"));
  EXPECT_TRUE(flat.local());
  flat.apply(json{{"units", "cells"}, {"operations", {{{"op", "peak"}, {"center", {32, 32}}}}}});
  EXPECT_TRUE(flat.local()) << "a landform stroke keeps a flat base local";
  flat.apply(json{{"units", "cells"}, {"operations", {{{"op", "fault"}, {"points", {{0, 10}, {64, 20}}}, {"throw", 20}}}}});
  EXPECT_FALSE(flat.local()) << "a fault's step needs the whole map";
  const Heightfield base = dem("N44W072.hgt", 600, 300, 65);
  EditSession real(test::device(), base);
  EXPECT_TRUE(real.local());
  real.apply(json{{"solve", "global"}, {"operations", json::array()}});
  EXPECT_FALSE(real.local());
  EXPECT_THROW(real.validate(json{{"solve", "nearby"}, {"operations", json::array()}}), Error);
  try {
    real.validate(json{{"solve", "global"}, {"locality", {{"falloff", 100}}}, {"operations", json::array()}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/locality"), std::string::npos) << e.what();
  }
}

// An explicit falloff bounds the changed cells: nothing moves farther than the falloff from the
// cells an operation changed, and the report says how many cells were solved.
TEST(EditLocality, ExplicitFalloffBoundsTheChange) {
  const Heightfield base = dem("frontrange_srtm3_758.asc", 100, 100, 129);
  const double cell = base.georef.cell_x;
  EditSession s(test::device(), base);
  s.apply(json{{"units", "cells"},
               {"locality", {{"falloff", 10}}},
               {"operations", {{{"op", "mesa"}, {"center", {64, 64}}, {"radius", 6}, {"elevation", 3000}, {"height", 100}, {"cap_detail", 0}}}}});
  const Heightfield& h = s.height();
  const json rep = s.report();
  EXPECT_EQ(rep["solve"], "local");
  EXPECT_NEAR(rep["falloff_m"].get<double>(), 10 * cell, 1e-9);
  EXPECT_GT(rep["locality"]["solved_cells"].get<size_t>(), rep["locality"]["changed_cells"].get<size_t>());
  size_t moved = 0;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      if (h.at(x, y) == base.at(x, y)) continue;
      ++moved;
      // mesa: disc 6 cells + rim 6 cells (+ the noise's rim) + falloff 10 cells (+ rounding)
      EXPECT_LE(std::hypot((x - 64) * cell, (y - 64) * base.georef.cell_y), (6 + 6 + 10 + 1.5) * std::max(cell, base.georef.cell_y))
          << x << "," << y;
    }
  EXPECT_GT(moved, 400u);
  // Only the mesa's rim ring is hard; its cap is free and keeps the base's relief (no flat disc).
  EXPECT_NEAR(h.at(64, 64), 3000.0, 20.0);
}

// "units": "map" takes the base's CRS coordinates (here degrees of the SRTM tile): the same crest
// in map units and in cells gives the same terrain.
TEST(EditLocality, MapUnitsMatchCells) {
  const Heightfield base = dem("N44W072.hgt", 600, 300, 97);
  const auto& gt = base.georef.geotransform;
  auto map = [&](double cx, double cy) {  // cell centre -> CRS
    return json::array({gt[0] + (cx + 0.5) * gt[1] + (cy + 0.5) * gt[2], gt[3] + (cx + 0.5) * gt[4] + (cy + 0.5) * gt[5]});
  };
  const double r = 6 * base.georef.cell_x;
  json in_cells = {{"units", "cells"},
                   {"operations", {{{"op", "crest"}, {"points", {{20, 30}, {70, 60}}}, {"elevation", 1500}, {"radius", 6}}}}};
  json in_map = {{"units", "map"},
                 {"operations", {{{"op", "crest"}, {"points", {map(20, 30), map(70, 60)}}, {"elevation", 1500}, {"radius", r}}}}};
  EditSession a(test::device(), base), b(test::device(), base);
  a.apply(in_cells);
  b.apply(in_map);
  const Heightfield &ha = a.height(), &hb = b.height();
  double worst = 0;
  for (size_t i = 0; i < ha.size(); ++i) worst = std::max(worst, std::abs(double(ha.z[i]) - hb.z[i]));
  EXPECT_LT(worst, 0.01);
  EXPECT_EQ(a.hard_cells(), b.hard_cells());
}

TEST(EditLocality, BadScriptsNameTheJsonPath) {
  const Heightfield base = dem("N44W072.hgt", 600, 300, 65);
  EditSession real(test::device(), base);
  EditSession flat(test::device(), *parse_flat_spec("flat:65x65@10"));
  auto message = [](EditSession& s, const json& script) {
    try {
      s.validate(script);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // map units without a georeferenced base
  const json map_script = {{"units", "map"}, {"operations", {{{"op", "crest"}, {"points", {{0, 0}, {1, 1}}}, {"elevation", 1}, {"radius", 1}}}}};
  EXPECT_NE(message(flat, map_script).find("/units: \"map\" coordinates need a georeferenced base"), std::string::npos)
      << message(flat, map_script);
  // a primitive 50 km off the grid
  const json off = {{"operations",
                     {{{"op", "noise", }, {"amplitude", 1}, {"wavelength", 100}},
                      {{"op", "crest"}, {"points", {{50000, 100}, {51000, 200}}}, {"elevation", 900}, {"radius", 300}}}}};
  const std::string m_off = message(real, off);
  EXPECT_NE(m_off.find("/operations/1/points: the primitive lies wholly outside the 65x65 grid"), std::string::npos) << m_off;
  // a tensor primitive off the grid names the primitive
  const json off_t = {{"operations",
                       {{{"op", "tensor"},
                         {"primitives", {{{"shape", "disc"}, {"center", {-9000, 100}}, {"disc_radius", 100}, {"radius", 200}}}}}}}};
  EXPECT_NE(message(real, off_t).find("/operations/0/primitives/0/center: the primitive lies wholly outside"), std::string::npos)
      << message(real, off_t);
  // near the grid, within its reach: accepted
  const json near = {{"units", "cells"}, {"operations", {{{"op", "crest"}, {"points", {{-5, 10}, {-5, 20}}}, {"elevation", 900}, {"radius", 8}}}}};
  EXPECT_EQ(message(real, near), "no error");
  // zero and negative widths
  for (double w : {0.0, -2.0}) {
    const json zw = {{"operations", {{{"op", "crest"}, {"points", {{100, 100}, {900, 900}}}, {"elevation", 900}, {"width", w}}}}};
    const std::string m = message(real, zw);
    EXPECT_NE(m.find("/operations/0/width: expected a"), std::string::npos) << m;
  }
}

TEST(EditLocality, SubCellSupportWarns) {
  const Heightfield base = dem("N44W072.hgt", 600, 300, 65);
  EditSession s(test::device(), base);
  const json script = {{"operations",
                        {{{"op", "crest"}, {"points", {{1000, 1000}, {2000, 2000}}}, {"elevation", 900}, {"radius", 5}},
                         {{"op", "crest"}, {"points", {{1000, 1000}, {2000, 2000}}}, {"elevation", 900}, {"radius", 500}}}}};
  const auto w = s.check(script);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].rfind("/operations/0/radius: 5 m is less than one cell", 0), 0u) << w[0];
  s.apply(script);
  // The sub-cell radius warns once (constraints cutting the terrain may add warnings of their own).
  const auto all = s.warnings();
  EXPECT_EQ(std::count_if(all.begin(), all.end(), [](const std::string& m) { return m.rfind("/operations/0/radius: 5 m", 0) == 0; }), 1);
  EXPECT_EQ(s.report()["warnings"].size(), all.size());
  EXPECT_TRUE(s.log()[0].contains("warnings"));
  EXPECT_TRUE(s.log()[1]["support"].is_array());
}

// Operations whose support is the whole grid (noise without a region) make the solve global:
// every cell may move, and the mean elevation is kept.
TEST(EditLocality, WholeGridSupportSolvesEverywhere) {
  const Heightfield base = dem("frontrange_srtm3_758.asc", 200, 200, 65);
  EditSession s(test::device(), base);
  s.apply(json{{"operations", {{{"op", "noise"}, {"amplitude", 20}, {"wavelength", 600}}}}});
  const Heightfield& h = s.height();
  EXPECT_EQ(s.log()[0]["support"], "grid");
  EXPECT_EQ(s.report()["locality"]["solved_cells"].get<size_t>(), base.size());
  double m0 = 0, m1 = 0;
  size_t moved = 0;
  for (size_t i = 0; i < h.size(); ++i) m0 += base.z[i], m1 += h.z[i], moved += h.z[i] != base.z[i];
  EXPECT_GT(moved, base.size() / 2);
  EXPECT_NEAR(m0 / double(h.size()), m1 / double(h.size()), 0.01);
}

TEST(EditLocality, CliWarnsAndRefusesOffGridWithoutOutput) {
  test::TempDir tmp;
  const std::string dem_path = test::data_path("dem/frontrange_srtm3_758.asc");
  const std::string warn_script = tmp.path("warn.json");
  {
    std::ofstream(warn_script) << json{{"operations", {{{"op", "free_crest"}, {"points", {{1000, 1000}, {5000, 5000}}}, {"height", 50}, {"radius", 10}}}}}.dump();
  }
  auto r = test::run_cli(fmt::format("edit {} --script {} -o {} -q", dem_path, warn_script, tmp.path("w.tif")));
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("WARNING: edit: /operations/0/radius: 10 m is less than one cell"), std::string::npos) << r.out;
  const std::string off_script = tmp.path("off.json");
  {
    std::ofstream(off_script) << json{{"units", "cells"}, {"operations", {{{"op", "crest"}, {"points", {{5000, 10}, {5100, 10}}}, {"elevation", 900}, {"radius", 10}}}}}.dump();
  }
  r = test::run_cli(fmt::format("edit {} --script {} -o {}", dem_path, off_script, tmp.path("o.tif")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("/operations/0/points: the primitive lies wholly outside"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.path("o.tif")));
}

// Each operation fades over its own falloff: a wide noise brush in one corner does not widen the
// fade of a thin crest in the other (with one falloff for all, the crest's change would spread
// over 3 x the brush's radius).
TEST(EditLocality, EachOperationFadesOverItsOwnFalloff) {
  const Heightfield base = dem("frontrange_srtm3_758.asc", 300, 300, 193);
  EditSession s(test::device(), base);
  s.apply(json{{"units", "cells"},
               {"operations",
                {{{"op", "noise"}, {"center", {30, 30}}, {"radius", 20}, {"falloff", 5}, {"amplitude", 30}, {"wavelength", 6}},
                 {{"op", "crest"}, {"points", {{130, 150}, {170, 160}}}, {"elevation", 4000}, {"radius", 4}}}}});
  const Heightfield& h = s.height();
  const double cmax = std::max(base.georef.cell_x, base.georef.cell_y);
  size_t near_crest = 0;
  for (int y = 100; y < h.height; ++y)
    for (int x = 100; x < h.width; ++x) {
      if (h.at(x, y) == base.at(x, y)) continue;
      ++near_crest;
      // crest radius 4 cells + falloff 3 x 4 cells (+ the changed faces' cell and rounding)
      EXPECT_LE(seg_dist(base, x, y, {130, 150}, {170, 160}), (4 + 12) * base.georef.cell_x + 2 * cmax) << x << "," << y;
    }
  EXPECT_GT(near_crest, 200u);
  EXPECT_EQ(s.report()["locality"]["falloffs_m"].size(), 2u);
}

// A new user's finding: `terracl edit` filled a DEM's nodata corners for the solve and wrote them
// out as elevations under the input's nodata value. The output keeps the base's mask unless
// --keep-filled asks for the filled cells.
TEST(EditLocality, CliOutputKeepsTheBaseNodataMask) {
  test::TempDir tmp;
  Heightfield base = dem("N44W072.hgt", 600, 300, 65);
  base.georef.nodata = -9999.0;
  size_t holes = 0;
  for (int y = 0; y < 65; ++y)
    for (int x = 0; x < 65; ++x)
      if (x + y < 20) base.at(x, y) = std::numeric_limits<float>::quiet_NaN(), ++holes;
  write_heightfield(base, tmp.path("base.tif"));
  {
    std::ofstream f(tmp.path("s.json"));
    f << R"({"units": "cells", "operations": [{"op": "crest", "points": [[25, 40], [50, 40]], "elevation": 900, "radius": 6}]})";
  }
  auto run = [&](const std::string& extra) {
    const auto r = test::run_cli("-q edit " + tmp.path("base.tif") + " --script " + tmp.path("s.json") + " -o " +
                                 tmp.path("out.tif") + extra);
    EXPECT_EQ(r.exit_code, 0) << r.out;
    return read_heightfield(tmp.path("out.tif"));
  };
  const Heightfield out = run("");
  EXPECT_EQ(out.count_nodata(), holes);
  for (int y = 0; y < 65; ++y)
    for (int x = 0; x < 65; ++x) EXPECT_EQ(std::isnan(out.at(x, y)), x + y < 20) << x << "," << y;
  EXPECT_NEAR(out.at(35, 40), 900.0, 1.0) << "the edit itself happened";
  EXPECT_EQ(run(" --keep-filled").count_nodata(), 0u);
}

// A crest pins its line at its elevation; its flanks must not rise above it beside the pinned cells.
// With the sharp profile's top rounded (as free crests have it) a 150 m crest with a bend, as a
// studio stroke draws it, rose to 151.0 m beside the bend; the crest keeps the plain profile.
TEST(EditLocality, CrestDoesNotRiseAboveItsElevationAtABend) {
  EditSession s(test::device(), *parse_flat_spec("flat:257x257@10"));
  s.apply(json::parse(R"({"operations": [{"op": "crest", "points": [[300, 1000], [1300, 700], [2300, 1000]],
                                          "elevation": 150, "height": 150, "radius": 205}]})"));
  const Heightfield& h = s.height();
  const float top = *std::max_element(h.z.begin(), h.z.end());
  EXPECT_NEAR(top, 150.0f, 0.01f);
}

// A river 10 m below the plains of the Front Range (the east edge of the bundled DEM) with its banks
// to the terrain (`"bank_height": "terrain"`) opens as a trough flush with the plain: nothing beside
// it rises above the base. With a fixed bank height above the cut, the excess lifts the ground past
// r (the raised lobe of the river_valley example at the mountain front: +214 m).
TEST(EditLocality, RiverBanksToTheTerrainStayFlushWithThePlain) {
  const Heightfield base = dem("frontrange_srtm3_758.asc", 629, 250, 129);
  // West to east across the hogbacks of the mountain front onto the plain, 10 m below the lowest
  // ground upstream (a bed that descends and cuts through the ridges).
  const std::array<double, 2> a{0, 64}, b{128, 70};
  json pts = json::array();
  double z = 1e30;
  for (int x = 0; x <= 128; x += 8) {
    const double y = a[1] + (b[1] - a[1]) * x / 128.0;
    z = std::min(z, double(base.at(x, int(std::lround(y)))) - 10);
    pts.push_back({x, y, z});
  }
  const double r_cells = 20, r = r_cells * base.georef.cell_x;
  auto rise = [&](const json& bank) {
    json river = {{"op", "river"}, {"points", pts}, {"width", 2 * r_cells}, {"profile", "flat"}, {"bank_height", bank}};
    EditSession s(test::device(), base);
    s.apply(json{{"units", "cells"}, {"operations", {river}}});
    const Heightfield& h = s.height();
    double worst = -1e30;
    for (int y = 0; y < base.height; ++y)
      for (int x = 0; x < base.width; ++x) {
        const double d = seg_dist(base, x, y, a, b);
        if (d >= 1.1 * r && d <= 2.5 * r) worst = std::max(worst, double(h.at(x, y)) - base.at(x, y));
      }
    return worst;
  };
  const double flush = rise("terrain"), lobe = rise(60.0);
  std::printf("river beside the plain, 1.1-2.5 r: banks to the terrain rise %.2f m, a 60 m bank %.1f m\n", flush, lobe);
  EXPECT_LT(flush, 2.0) << "the valley's banks stand above the plain";
  EXPECT_GT(lobe, 20.0) << "a bank above the cut should lift the plain (the case the option is for)";
}
