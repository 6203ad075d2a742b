// SPDX-License-Identifier: Apache-2.0
// D8 pointers and watersheds against SAGA 8.5 and GRASS 8.2 on a real 30 m DEM: their outputs on
// data/crops/presidential_utm30_192.tif are committed in data/anchors/ (remade by
// scripts/make-hydrology-anchors.sh; data/anchors/README.md says what each holds). D8 is only
// defined up to ties and flats, where each tool has its own order; everywhere else (a unique
// steepest, strictly lower neighbour: d8_unambiguous.tif) every correct D8 must agree.
#include "test_helpers.hpp"

#include <terracl/io.hpp>

#include <cmath>
#include <string>

using namespace terracl;

namespace {

const std::string kDem = "crops/presidential_utm30_192.tif";

Heightfield anchor(const std::string& name) { return read_heightfield(test::data_path("anchors/" + name)); }

Heightfield run(const test::TempDir& dir, const std::string& args, const std::string& out) {
  const auto r = test::run_cli(args + " -o " + dir.path(out));
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.out;
  return read_heightfield(dir.path(out));
}

}  // namespace

TEST(HydrologyAnchors, D8PointersEqualSagaAndGrassWhereverTheSteepestDescentIsUnique) {
  test::TempDir dir;
  const std::string dem = test::data_path(kDem);
  const Heightfield esri = run(dir, "drainage " + dem + " --product d8_esri", "esri.tif");
  const Heightfield grass = run(dir, "drainage " + dem + " --product d8_grass", "grass.tif");
  const Heightfield saga = anchor("saga_wl_fdir_esri.tif"), filldir = anchor("grass_filldir_drainage.tif");
  const Heightfield mask = anchor("d8_unambiguous.tif");
  ASSERT_EQ(esri.z.size(), mask.z.size());
  const int w = mask.width, h = mask.height;
  size_t unique = 0, saga_same = 0, all_same = 0, inner_unique = 0, grass_same = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      all_same += esri.z[i] == saga.z[i];
      if (mask.z[i] != 1.0f) continue;
      ++unique;
      saga_same += esri.z[i] == saga.z[i];
      EXPECT_EQ(esri.z[i], saga.z[i]) << "SAGA, cell " << x << "," << y;
      // r.fill.dir points every border cell off the map, so only inner cells compare.
      if (x == 0 || y == 0 || x == w - 1 || y == h - 1) continue;
      ++inner_unique;
      grass_same += grass.z[i] == filldir.z[i];
      EXPECT_EQ(grass.z[i], filldir.z[i]) << "GRASS r.fill.dir, cell " << x << "," << y;
    }
  EXPECT_EQ(unique, 36752u);  // the mask as made (README.md)
  EXPECT_EQ(saga_same, unique);
  EXPECT_EQ(grass_same, inner_unique);
  // Ties and flats (112 cells) are each tool's choice; SAGA and terracl still differ on only 31.
  EXPECT_GE(all_same, esri.z.size() - 31);
}

TEST(HydrologyAnchors, WatershedsEqualSagaAndGrassBasins) {
  test::TempDir dir;
  const std::string dem = test::data_path(kDem);
  // Basins with no tie or flat in or around them: SAGA's Upslope Area, every cell equal.
  const Heightfield exact = run(dir,
                                "watershed " + dem +
                                    " --snap 0 --points '313723.586,4909362.008;311593.586,4909032.008;"
                                    "312043.586,4905672.008'",
                                "exact.tif");
  const Heightfield saga = anchor("saga_basins_exact.tif");
  ASSERT_EQ(exact.z.size(), saga.z.size());
  size_t inside = 0;
  for (size_t i = 0; i < saga.z.size(); ++i) {
    const float t = std::isfinite(exact.z[i]) ? exact.z[i] : 0.0f;  // terracl: nodata outside every basin
    ASSERT_EQ(t, saga.z[i]) << "cell " << i % exact.width << "," << i / exact.width;
    inside += saga.z[i] > 0;
  }
  EXPECT_EQ(inside, 711u + 509 + 446);

  // Main-stream basins of 3,000-12,500 cells: GRASS's r.watershed -s routes by least cost (A*),
  // not strictly down the steepest slope, so a few cells at ties and flats go the other way.
  const Heightfield main = run(dir,
                               "watershed " + dem +
                                   " --snap 0 --points '311143.586,4910772.008;311083.586,4905222.008;"
                                   "314053.586,4910772.008'",
                               "main.tif");
  const Heightfield grass = anchor("grass_basins_main.tif");
  for (int label = 1; label <= 3; ++label) {
    size_t both = 0, either = 0;
    for (size_t i = 0; i < grass.z.size(); ++i) {
      const bool a = main.z[i] == float(label), b = grass.z[i] == float(label);
      both += a && b;
      either += a || b;
    }
    ASSERT_GT(either, 2000u) << label;
    EXPECT_GE(double(both) / double(either), 0.995) << "basin " << label << ": IoU with GRASS";
  }
}
