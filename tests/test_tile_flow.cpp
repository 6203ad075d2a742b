// SPDX-License-Identifier: Apache-2.0
// Exact tiled D8 flow accumulation (Barnes 2017) against the untiled `drainage`: bit for bit on
// odd sizes, tiles down to 2 cells, nodata, flats and depressions resolved by the untiled epsilon
// fill, a river crossing many tiles and a window of the real SRTM tile; through the pipeline; and
// the refusals (pits and flats, D-infinity, breaching) that name their reason.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>

#include "test_helpers.hpp"
#include "tile_test_helpers.hpp"

namespace terracl {
namespace {

// The drainage stage's output (area in m2) from the untiled accumulation.
Heightfield untiled_area(const Heightfield& h) {
  const analysis::D8Result r = analysis::d8_flow(h);
  Heightfield out(h.width, h.height);
  for (size_t i = 0; i < out.size(); ++i) out.z[i] = std::isnan(h.z[i]) ? NAN : float(r.cells[i] * r.cell_area_m2);
  return out;
}

Heightfield tiled_area(const Heightfield& h, int tile, bool global_phase = true,
                       analysis::TiledFlowStats* stats = nullptr) {
  test::MemoryTiles m(h);
  auto read = [&](int x, int y, int w, int ht) { return m.read(x, y, w, ht); };
  auto write = [&](int x, int y, const Heightfield& core) { m.write(x, y, core); };
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  const auto st =
      analysis::d8_accumulation_tiled(h.width, h.height, tile, cx, cy, cx * cy, read, write, {}, global_phase);
  if (stats) *stats = st;
  m.expect_each_cell_written_once();
  return m.out;
}

using test::bit_differences;

// The surface a tiled run is given: the untiled epsilon fill (pits and flats drained).
Heightfield drained(const Heightfield& h) { return analysis::priority_flood_fill(h, true).filled; }

TEST(TileFlow, EqualsUntiledDrainageOfTheRawSurfaceBitForBit) {
  // The tiled accumulation of the epsilon-filled surface equals the untiled drainage of the raw
  // one (which fills it itself): flats and pits are resolved as the untiled run resolves them.
  for (auto [w, h, tile] : {std::tuple{97, 61, 16}, {64, 64, 8}, {131, 37, 7}, {50, 50, 49}, {33, 71, 2}, {40, 9, 3}}) {
    const Heightfield raw = test::pitted_terrain(w, h, unsigned(w * 7 + h));
    const Heightfield ref = untiled_area(raw);
    analysis::TiledFlowStats st;
    const Heightfield got = tiled_area(drained(raw), tile, true, &st);
    EXPECT_EQ(bit_differences(ref, got), 0u) << w << " x " << h << " tile " << tile;
    EXPECT_EQ(st.valid_cells, raw.size());
    EXPECT_EQ(st.outflow_cells, double(raw.size()));  // all flow leaves the raster
  }
}

TEST(TileFlow, EqualsUntiledWithNodata) {
  Heightfield raw = test::pitted_terrain(120, 90, 5, 0.02);
  for (int y = 30; y < 60; ++y)  // a nodata lake crossing tile borders
    for (int x = 20; x < 45; ++x) raw.at(x, y) = NAN;
  const Heightfield ref = untiled_area(raw);
  const Heightfield got = tiled_area(drained(raw), 17);
  EXPECT_EQ(bit_differences(ref, got), 0u);
  EXPECT_TRUE(std::isnan(got.at(30, 40)));
}

TEST(TileFlow, RiverAcrossManyTilesNeedsTheGlobalPhase) {
  // A meandering valley from the west edge to the east edge of a 200 x 60 raster, over tiles of 6:
  // its outlet gathers the whole valley; without the perimeter graph each tile sees only its part.
  Heightfield raw(200, 60);
  for (int y = 0; y < raw.height; ++y)
    for (int x = 0; x < raw.width; ++x) {
      const double centre = 30 + 20 * std::sin(x * 0.07);
      raw.at(x, y) = float(500 - 1.5 * x + 3 * std::abs(y - centre));
    }
  const Heightfield ref = untiled_area(raw);
  analysis::TiledFlowStats st;
  const Heightfield got = tiled_area(drained(raw), 6, true, &st);
  EXPECT_EQ(bit_differences(ref, got), 0u);
  EXPECT_GT(st.tiles, 300);
  const double cell = raw.georef.cell_x * raw.georef.cell_y;
  float outlet = 0;
  for (int y = 0; y < raw.height; ++y) outlet = std::max(outlet, got.at(raw.width - 1, y));
  EXPECT_GT(outlet / cell, 1000.f);  // the river's mouth drains more than a thousand cells
  const Heightfield local = tiled_area(drained(raw), 6, false);
  EXPECT_GT(bit_differences(ref, local), 1000u);
}

TEST(TileFlow, RealDemEqualsUntiled) {
  const Heightfield t = test::srtm_crop(401, 301, 500, 600);
  const Heightfield ref = untiled_area(t);
  for (int tile : {64, 37}) EXPECT_EQ(bit_differences(ref, tiled_area(drained(t), tile)), 0u) << tile;
}

TEST(TileFlow, PitsAndFlatsAreRefusedNamingTheCell) {
  Heightfield t(20, 20, 10.f);  // one flat: nothing drains inside
  try {
    tiled_area(t, 8);
    FAIL() << "a flat ran tiled";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cell (1, 1)"), std::string::npos) << m;
    EXPECT_NE(m.find("epsilon"), std::string::npos) << m;
  }
  EXPECT_THROW(tiled_area(t, 1), Error);
}

// Pipeline runs: read -> drainage -> write, untiled from the raw surface and tiled from its epsilon
// fill; and behind a crop of the filled surface (the tiled drainage then reads a temporary tiled
// file), in cells.
TEST(TileFlow, PipelineDrainageEqualsUntiled) {
  test::TempDir dir;
  const Heightfield t = test::srtm_crop(203, 157, 300, 200, test::Holes{60, 40, 90, 70, 0, 0});
  const std::string raw = dir.path("raw.tif"), in = dir.path("in.tif");
  write_heightfield(t, raw);
  write_heightfield(drained(t), in);
  for (const char* which : {"u", "t"}) {
    const std::string out = dir.path(which);
    const std::string src = which[0] == 'u' ? raw : in;  // untiled: the raw surface (it fills itself)
    const std::string doc =
        R"([")" + src + R"(", "drainage", ")" + out + R"(/a.tif", {"type": "read", "filename": ")" + in +
        R"("}, {"type": "crop", "x": 3, "y": 5, "width": 190}, {"type": "drainage", "units": "cells"}, ")" + out +
        R"(/b.tif"])";
    Pipeline p = Pipeline::parse(json::parse(doc), "flow", "flow.json");
    p.validate();
    RunOptions ro;
    ro.device = []() -> Device& { return test::device(); };
    ro.write_resolved = false;
    RunReport r;
    if (which[0] == 'u') {
      p.run(ro, r);
    } else {
      TileOptions to;
      to.tile = 29;
      run_tiled(p, to, ro, r);
    }
  }
  for (const char* f : {"a.tif", "b.tif"}) {
    const Heightfield a = read_heightfield(dir.path(std::string("u/") + f));
    const Heightfield b = read_heightfield(dir.path(std::string("t/") + f));
    ASSERT_EQ(a.width, b.width) << f;
    ASSERT_EQ(a.height, b.height) << f;
    EXPECT_EQ(bit_differences(a, b), 0u) << f;
    EXPECT_EQ(a.georef.vertical_units, b.georef.vertical_units) << f;
    EXPECT_EQ(a.georef.geotransform, b.georef.geotransform) << f;
  }
  EXPECT_EQ(read_heightfield(dir.path("t/b.tif")).georef.vertical_units, "cells");
}

TEST(TileFlow, DinfBreachAndRawSurfacesAreRefusedTiled) {
  test::TempDir dir;
  Heightfield t = test::pitted_terrain(64, 64, 3);
  const std::string in = dir.path("in.tif");
  write_heightfield(t, in);
  struct Case {
    std::string stage, expect;
  };
  for (const Case& c : {Case{R"({"type": "drainage", "method": "dinf"})", "cannot run tiled: D-infinity"},
                        Case{R"("breach")", "cannot run tiled: a cell's breach path"}}) {
    Pipeline p =
        Pipeline::parse(json::parse("[\"" + in + "\", " + c.stage + ", \"" + dir.path("o.tif") + "\"]"), "x", "x.json");
    p.validate();
    const std::string e = test::tiled_run_error<UsageError>(p);
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.stage << ": " << e;
  }
  // The raw surface has pits: the tiled drainage names one and leaves no output behind.
  Pipeline p =
      Pipeline::parse(json::parse("[\"" + in + "\", \"drainage\", \"" + dir.path("o.tif") + "\"]"), "x", "x.json");
  p.validate();
  const std::string e = test::tiled_run_error(p);
  EXPECT_NE(e.find("no lower neighbour"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(dir.path("o.tif")));
}

}  // namespace
}  // namespace terracl
