// SPDX-License-Identifier: Apache-2.0
// ConstraintSet::band (hypre's band reader: each MPI rank rasterises only its rows): the bands of
// a split, each given only its rows of the current / mask / elevation rasters, together hold
// exactly the hard cells and values of the whole grid's set.
#include "test_helpers.hpp"

#include <terracl/constraints.hpp>
#include <terracl/error.hpp>

using namespace terracl;

namespace {

Heightfield rows_of(const Heightfield& h, int r0, int r1) {
  Heightfield b(h.width, r1 - r0);
  b.georef = h.georef;
  std::copy(h.z.begin() + size_t(r0) * h.width, h.z.begin() + size_t(r1) * h.width, b.z.begin());
  return b;
}

}  // namespace

TEST(ConstraintBands, BandsTogetherEqualTheWholeSet) {
  const int W = 47, H = 39;
  const Heightfield cur = test::smooth_terrain(W, H, 10.0, 300.0, 2);
  Heightfield mask(W, H, 0.f), elev(W, H, 0.f);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      mask.z[size_t(y) * W + x] = (x * 7 + y * 3) % 11 == 0 ? 1.f : 0.f;
      elev.z[size_t(y) * W + x] = 100.f + x + 0.5f * y;
    }
  // Every kind, shapes crossing band edges, an omitted z on a vertex and a point in other bands,
  // a frozen polygon, overlapping kinds (priority) and two points on one cell (average).
  const nlohmann::json doc = nlohmann::json::parse(R"({"units": "pixels",
    "points": [{"x": 3, "y": 2, "z": 900}, [40, 30], {"x": 20.4, "y": 18.6, "z": 5}, {"x": 20, "y": 19, "z": 7}],
    "polylines": [{"points": [[2, 35, 100], [44, 3], [30, 30, 60]], "width": 3}],
    "polygons": [{"points": [[5, 5], [25, 8], [15, 33]], "z": 400}, {"points": [[30, 10], [45, 12], [40, 25]]}]})");
  ConstraintSet whole(W, H);
  whole.add_rasters(mask, elev, "mask");
  add_constraints_json(whole, doc, Georef(), &cur, "doc");
  whole.add_border(cur);
  std::vector<uint32_t> wi;
  std::vector<float> wv;
  whole.hard_cells(wi, wv);
  ASSERT_GT(wi.size(), 200u);

  for (const int parts : {2, 3, 7}) {
    std::vector<uint32_t> bi;
    std::vector<float> bv;
    for (int p = 0; p < parts; ++p) {
      const int r0 = H * p / parts, r1 = H * (p + 1) / parts;
      ConstraintSet b = ConstraintSet::band(W, H, r0, r1 - r0);
      b.outside_current = [&](int x, int y) { return double(cur.at(x, y)); };
      b.add_rasters(rows_of(mask, r0, r1), rows_of(elev, r0, r1), "mask");
      const Heightfield cb = rows_of(cur, r0, r1);
      add_constraints_json(b, doc, Georef(), &cb, "doc");
      b.add_border(cb);
      std::vector<uint32_t> i;
      std::vector<float> v;
      b.hard_cells(i, v);
      for (uint32_t k : i) EXPECT_TRUE(int(k / W) >= r0 && int(k / W) < r1) << k;
      bi.insert(bi.end(), i.begin(), i.end());
      bv.insert(bv.end(), v.begin(), v.end());
    }
    EXPECT_EQ(bi, wi) << parts << " bands";
    EXPECT_EQ(bv, wv) << parts << " bands";
  }
  // Without a lookup, an omitted z in another band is refused (not silently zero).
  ConstraintSet b = ConstraintSet::band(W, H, 0, 10);
  const Heightfield cb = rows_of(cur, 0, 10);
  try {
    add_constraints_json(b, doc, Georef(), &cb, "doc");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("doc/points/1/z"), std::string::npos) << e.what();
  }
  // A band outside the grid and a raster of the wrong height are errors.
  EXPECT_THROW(ConstraintSet::band(W, H, 30, 10), Error);
  EXPECT_THROW(b.add_rasters(mask, elev, "mask"), Error);
}
