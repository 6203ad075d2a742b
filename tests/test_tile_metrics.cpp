// SPDX-License-Identifier: Apache-2.0
// Tiled metrics (docs/scale.md, "Tiled metrics"): the report's local statistics (elevation, slope
// mean / max / quantiles / histogram, Laplacian curvature) equal to the untiled report bit for bit
// on odd sizes, tiles that do not divide them, nodata and ties; the global figures left out with a
// note; and the exact accumulator behind the sums.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "../host/src/analysis/exact_sum.hpp"
#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

json read_json(const std::string& f) {
  std::ifstream in(f);
  EXPECT_TRUE(in.good()) << f;
  return json::parse(in);
}

}  // namespace

TEST(TileMetrics, ExactSumIsExactAndOrderIndependent) {
  analysis::ExactSum a;
  a.add(1e16), a.add(1.0), a.add(-1e16);
  EXPECT_EQ(a.value(), 1.0);  // a double sum gives 0
  std::mt19937_64 rng(7);
  std::vector<double> v;
  for (int i = 0; i < 20000; ++i)
    v.push_back(std::ldexp(std::uniform_real_distribution<double>(-1, 1)(rng), int(rng() % 120) - 60));
  v.push_back(5e-324);  // a subnormal
  analysis::ExactSum fwd, parts[3];
  for (size_t i = 0; i < v.size(); ++i) fwd.add(v[i]), parts[i % 3].add(v[i]);
  std::shuffle(v.begin(), v.end(), rng);
  analysis::ExactSum shuffled;
  for (double d : v) shuffled.add(d);
  analysis::ExactSum merged = parts[2];
  merged.merge(parts[0]), merged.merge(parts[1]);
  EXPECT_EQ(fwd.digits(), shuffled.digits());
  EXPECT_EQ(fwd.digits(), merged.digits());
  EXPECT_EQ(fwd.value(), merged.value());
  long double naive = 0;
  for (double d : v) naive += d;
  EXPECT_NEAR(double(fwd.value()), double(naive), 1e-12 * std::fabs(double(naive)) + 1e-30);
}

TEST(TileMetrics, LocalStatisticsEqualUntiledBitForBit) {
  test::TempDir dir;
  // An odd-sized SRTM crop with a nodata hole and voids across tiles, and a flat block (ties at 0).
  const int w = 213, h = 161;
  // The hole, then the flat block, then the voids (which may fall into either).
  Heightfield t = test::srtm_crop(w, h, 500, 300, test::Holes{60, 30, 120, 80, 0, 5});
  for (int y = 100; y < 150; ++y)
    for (int x = 20; x < 90; ++x) t.at(x, y) = 400.0f;
  std::mt19937 rng(5);
  for (int k = 0; k < 150; ++k) t.at(int(rng() % w), int(rng() % h)) = NAN;
  const std::string in = dir.path("in.tif");
  write_heightfield(t, in);

  for (int tile : {37, 64}) {
    for (const char* which : {"u", "t"}) {
      const std::string out = dir.path(which);
      const std::string doc = R"([")" + in + R"(", {"type": "metrics", "json": ")" + out + R"(/m.json"},
          {"type": "crop", "x": 7, "y": 4, "width": 150}, {"type": "metrics", "json": ")" + out + R"(/c.json"}, ")" +
                              out + R"(/c.tif"])";
      Pipeline p = Pipeline::parse(json::parse(doc), "tiles", "tiles.json");
      p.validate();
      RunOptions ro;
      ro.device = []() -> Device& { return test::device(); };
      ro.write_resolved = false;
      RunReport r;
      if (which[0] == 'u') {
        p.run(ro, r);
      } else {
        TileOptions to;
        to.tile = tile;
        run_tiled(p, to, ro, r);
      }
    }
    for (const char* f : {"m.json", "c.json"}) {
      SCOPED_TRACE(std::string(f) + " tile " + std::to_string(tile));
      json u = read_json(dir.path(std::string("u/") + f)), tj = read_json(dir.path(std::string("t/") + f));
      for (const char* k : {"spectral_slope", "fill", "breach", "drainage"}) {
        EXPECT_TRUE(u.contains(k)) << k;
        EXPECT_FALSE(tj.contains(k)) << k;
        u.erase(k);
      }
      ASSERT_TRUE(tj.contains("tiled"));
      EXPECT_NE(tj["tiled"].get<std::string>().find("need the whole raster"), std::string::npos);
      tj.erase("tiled");
      // The runs' pipeline files differ in their output folder, so do their hashes.
      u["provenance"].erase("terracl:pipeline_hash");
      tj["provenance"].erase("terracl:pipeline_hash");
      std::string stages = u["provenance"]["terracl:stages"].get<std::string>();
      for (size_t p; (p = stages.find(dir.path("u"))) != std::string::npos;)
        stages.replace(p, dir.path("u").size(), dir.path("t"));
      u["provenance"]["terracl:stages"] = stages;
      EXPECT_EQ(u, tj) << "untiled:\n" << u.dump(1) << "\ntiled:\n" << tj.dump(1);
      EXPECT_GT(u["nodata_cells"].get<size_t>(), 2500u);
      EXPECT_EQ(u["slope_deg"]["quantiles"]["p05"].get<double>(), 0.0) << "the flat block's ties";
    }
  }
}

}  // namespace terracl
