// SPDX-License-Identifier: Apache-2.0
// D8 pointer rasters (drainage --product d8_esri|d8_grass): the codings as ESRI's and GRASS's
// documentation give them, and accumulation recomputed by following the pointers equal to the
// drainage area the stage writes.
#include "test_helpers.hpp"

#include <terracl/io.hpp>

#include <cmath>
#include <map>
#include <utility>

using namespace terracl;

namespace {

// (dx, dy) on the map, y growing south, by compass direction, and each GIS's code for it.
const std::map<int, std::pair<int, int>> kEsri = {{1, {1, 0}},    {2, {1, 1}},    {4, {0, 1}},  {8, {-1, 1}},
                                                  {16, {-1, 0}},  {32, {-1, -1}}, {64, {0, -1}}, {128, {1, -1}}};
const std::map<int, std::pair<int, int>> kGrass = {{1, {1, -1}}, {2, {0, -1}}, {3, {-1, -1}}, {4, {-1, 0}},
                                                   {5, {-1, 1}}, {6, {0, 1}},  {7, {1, 1}},   {8, {1, 0}}};

Heightfield run(const test::TempDir& dir, const std::string& in, const std::string& args, const std::string& name) {
  const auto r = test::run_cli("drainage '" + in + "' -o '" + dir.path(name) + "' " + args);
  EXPECT_EQ(r.exit_code, 0) << r.out;
  return read_heightfield(dir.path(name));
}

}  // namespace

TEST(D8Pointer, EastwardPlaneFlowsEastInBothCodings) {
  test::TempDir dir;
  Heightfield h(12, 9);
  h.georef.cell_x = h.georef.cell_y = 30.0;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) h.at(x, y) = float(500 - 2 * x);
  write_heightfield(h, dir.path("plane.tif"));
  const Heightfield e = run(dir, dir.path("plane.tif"), "--product d8_esri", "e.tif");
  const Heightfield g = run(dir, dir.path("plane.tif"), "--product d8_grass", "g.tif");
  for (int y = 1; y < h.height - 1; ++y) {
    for (int x = 0; x < h.width - 1; ++x) {
      EXPECT_EQ(e.at(x, y), 1.0f) << x << "," << y;  // east
      EXPECT_EQ(g.at(x, y), 8.0f) << x << "," << y;
    }
    EXPECT_EQ(e.at(h.width - 1, y), 0.0f);  // the east edge: water leaves the grid
  }
}

TEST(D8Pointer, FollowingThePointersGivesTheDrainageArea) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  const Heightfield e = run(dir, in, "--product d8_esri", "e.tif");
  const Heightfield g = run(dir, in, "--product d8_grass", "g.tif");
  const Heightfield cells = run(dir, in, "--units cells", "a.tif");
  const int w = e.width, h = e.height;
  std::vector<double> acc(e.size(), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (std::isnan(e.at(x, y))) continue;
      // The two codings name the same neighbour.
      const int ce = int(e.at(x, y)), cg = int(g.at(x, y));
      ASSERT_EQ(ce == 0, cg == 0) << x << "," << y;
      if (ce) ASSERT_EQ(kEsri.at(ce), kGrass.at(cg)) << x << "," << y;
      // Walk downstream, adding this cell to every cell it passes (brute force, O(n * path)).
      int u = x, v = y;
      for (size_t steps = 0; steps <= e.size(); ++steps) {
        acc[size_t(v) * w + u] += 1.0;
        const int c = int(e.at(u, v));
        if (c == 0) break;
        const auto [dx, dy] = kEsri.at(c);
        u += dx, v += dy;
        ASSERT_TRUE(u >= 0 && v >= 0 && u < w && v < h) << "a pointer leaves the grid at " << u << "," << v;
        ASSERT_FALSE(std::isnan(e.at(u, v))) << "a pointer enters nodata";
      }
    }
  for (size_t i = 0; i < acc.size(); ++i) {
    if (std::isnan(cells.z[i])) continue;
    ASSERT_EQ(acc[i], double(cells.z[i])) << i;
  }
}

TEST(D8Pointer, DinfAndTiledRunsAreRefusedWithTheReason) {
  test::TempDir dir;
  const std::string in = test::data_path("crops/presidential_128x96.tif");
  auto r = test::run_cli("drainage '" + in + "' -o '" + dir.path("x.tif") + "' --product d8_esri --method dinf");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("use method d8"), std::string::npos) << r.out;
  r = test::run_cli("drainage '" + in + "' -o '" + dir.path("y.tif") + "' --product d8_grass --tile 64");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("runs untiled only"), std::string::npos) << r.out;
}
