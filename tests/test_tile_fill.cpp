// SPDX-License-Identifier: Apache-2.0
// Exact tiled Priority-Flood (Barnes 2016) against the untiled fill: bit for bit on rasters with
// many tiles, odd sizes, nodata and depressions spanning tiles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

// Tiled fill of `h` held in memory; returns the assembled result and checks every cell is written once.
Heightfield fill_tiled(const Heightfield& h, int tile, analysis::TiledFillStats* stats = nullptr) {
  test::MemoryTiles m(h);
  auto read = [&](int x, int y, int w, int ht) { return m.read(x, y, w, ht); };
  auto write = [&](int x, int y, const Heightfield& core) { m.write(x, y, core); };
  const auto st = analysis::priority_flood_fill_tiled(h.width, h.height, tile, read, write);
  if (stats) *stats = st;
  m.expect_each_cell_written_once();
  return m.out;
}

using test::bit_differences;

TEST(TileFill, EqualsUntiledBitForBitOnManyTilesAndOddSizes) {
  for (auto [w, h, tile] : {std::tuple{97, 61, 16}, {64, 64, 8}, {131, 37, 7}, {50, 50, 49}, {33, 71, 2}}) {
    const Heightfield t = test::pitted_terrain(w, h, unsigned(w * 7 + h));
    const Heightfield ref = analysis::priority_flood_fill(t).filled;
    const Heightfield got = fill_tiled(t, tile);
    EXPECT_EQ(bit_differences(ref, got), 0u) << w << " x " << h << " tile " << tile;
  }
}

TEST(TileFill, EqualsUntiledWithNodata) {
  Heightfield t = test::pitted_terrain(120, 90, 5, 0.02);
  for (int y = 30; y < 60; ++y)  // a nodata lake crossing tile borders
    for (int x = 20; x < 45; ++x) t.at(x, y) = NAN;
  const Heightfield ref = analysis::priority_flood_fill(t).filled;
  const Heightfield got = fill_tiled(t, 17);
  EXPECT_EQ(bit_differences(ref, got), 0u);
  EXPECT_TRUE(std::isnan(got.at(30, 40)));
}

TEST(TileFill, DepressionSpanningTilesFillsToItsSpillLevel) {
  // A 100 m plateau with a bowl 60 cells wide (down to 10 m) whose rim is broken at one point at
  // 70 m, on a tile of 16: the whole bowl, in 16 tiles, must rise to exactly 70 m.
  Heightfield t(81, 81, 100.f);
  for (int y = 0; y < 81; ++y)
    for (int x = 0; x < 81; ++x) {
      const double r = std::hypot(x - 40, y - 40);
      if (r < 30) t.at(x, y) = float(10 + r);
    }
  for (int x = 70; x < 81; ++x) t.at(x, 40) = 70.f;  // the spillway to the east border
  const Heightfield ref = analysis::priority_flood_fill(t).filled;
  analysis::TiledFillStats st;
  const Heightfield got = fill_tiled(t, 16, &st);
  EXPECT_EQ(bit_differences(ref, got), 0u);
  EXPECT_EQ(got.at(40, 40), 70.f);
  EXPECT_EQ(st.tiles, 36);
  // Without the graph phase the centre tile would keep its own (lower) level: the test can fail.
  EXPECT_GT(got.at(40, 40), t.at(40, 40));
}

TEST(TileFill, RealDemEqualsUntiled) {
  const Heightfield t = test::srtm_crop(401, 301, 500, 600);
  const Heightfield ref = analysis::priority_flood_fill(t).filled;
  EXPECT_EQ(bit_differences(ref, fill_tiled(t, 64)), 0u);
}

TEST(TileFill, RejectsBadTileSizes) {
  Heightfield t(8, 8, 1.f);
  EXPECT_THROW(fill_tiled(t, 1), Error);
}

}  // namespace
}  // namespace terracl
