// SPDX-License-Identifier: Apache-2.0
// D-infinity (analysis::dinf_flow) against answers computed independently of it:
//  - a plain transcription of Tarboton (1997) (angles by atan2, then clipping; accumulation by
//    visiting cells from the highest down instead of terracl's donor counting), on an off-centre
//    cone, a real 30 m DEM and a real DEM in degrees (rectangular cells);
//  - the exact answer on inclined planes: D-infinity's flow lines are `cell * max(|cos t|, |sin t|)`
//    apart for a flow direction t, so a cell collects (upslope length) * max(|cos t|, |sin t|) / cell
//    cells. SAGA's D-infinity (ta_hydrology 0, METHOD 3) gives the same cells on these planes; on real
//    DEMs it is another method (a 4-neighbour aspect with a D8 fallback; docs/analysis.md).
#include "test_helpers.hpp"

#include <terracl/analysis.hpp>
#include <terracl/io.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

using namespace terracl;

namespace {

// Tarboton's facets, as in his paper's table: e1 the cardinal neighbour, e2 the diagonal one. The
// order (E,SE) (S,SE) (S,SW) (W,SW) (W,NW) (N,NW) (N,NE) (E,NE) and "the first steepest wins" are
// the tie convention (any order is correct; this one is terracl's).
struct Facet {
  int c1x, c1y, c2x, c2y;
};
const Facet kFacets[8] = {{1, 0, 1, 1},   {0, 1, 1, 1},   {0, 1, -1, 1}, {-1, 0, -1, 1},
                          {-1, 0, -1, -1}, {0, -1, -1, -1}, {0, -1, 1, -1}, {1, 0, 1, -1}};

std::vector<double> reference_dinf(const Heightfield& h) {
  const int w = h.width, ht = h.height;
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  const size_t n = h.z.size();
  struct Out {
    int to1 = -1, to2 = -1;
    double p1 = 0;
  };
  std::vector<Out> out(n);
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const double e0 = h.at(x, y);
      if (std::isnan(e0)) continue;
      double best = 0;
      for (const Facet& f : kFacets) {
        const int x1 = x + f.c1x, y1 = y + f.c1y, x2 = x + f.c2x, y2 = y + f.c2y;
        if (x2 < 0 || y2 < 0 || x2 >= w || y2 >= ht) continue;  // the diagonal is the farther one
        const double e1 = h.at(x1, y1), e2 = h.at(x2, y2);
        if (std::isnan(e1) || std::isnan(e2)) continue;
        const double d1 = f.c1x != 0 ? cx : cy, d2 = f.c1x != 0 ? cy : cx;
        const double s1 = (e0 - e1) / d1, s2 = (e1 - e2) / d2, amax = std::atan(d2 / d1);
        double r = std::atan2(s2, s1), s = std::hypot(s1, s2);
        if (r < 0) {
          r = 0, s = s1;
        } else if (r > amax) {
          r = amax, s = (e0 - e2) / std::hypot(d1, d2);
        }
        if (!(s > best)) continue;
        best = s;
        const double p_diag = r / amax;
        Out& o = out[size_t(y) * w + x];
        o = Out{};
        if (p_diag <= 0) {
          o.to1 = y1 * w + x1, o.p1 = 1;
        } else if (p_diag >= 1) {
          o.to1 = y2 * w + x2, o.p1 = 1;
        } else {
          o.to1 = y1 * w + x1, o.to2 = y2 * w + x2, o.p1 = 1 - p_diag;
        }
      }
    }
  // Water only runs downhill (every receiver is strictly lower), so the highest cell first sees
  // each cell's whole inflow before it passes it on.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const float za = h.z[a], zb = h.z[b];
    return std::isnan(zb) ? !std::isnan(za) : za > zb;
  });
  std::vector<double> cells(n, 0.0);
  for (size_t i = 0; i < n; ++i) cells[i] = std::isnan(h.z[i]) ? 0.0 : 1.0;
  for (size_t i : order) {
    if (out[i].to1 >= 0) cells[size_t(out[i].to1)] += cells[i] * out[i].p1;
    if (out[i].to2 >= 0) cells[size_t(out[i].to2)] += cells[i] * (1 - out[i].p1);
  }
  return cells;
}

// The surface both route: terracl's epsilon fill (flats made to drain), which is not under test here.
Heightfield routed(Heightfield h) {
  analysis::fill_for_routing(h);
  return h;
}

void expect_same_as_reference(const Heightfield& surface, const char* what) {
  const analysis::DinfResult r = analysis::dinf_flow(surface);
  const std::vector<double> ref = reference_dinf(surface);
  size_t compared = 0;
  double worst = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    if (std::isnan(surface.z[i])) continue;
    ++compared;
    worst = std::max(worst, std::fabs(r.cells[i] - ref[i]) / ref[i]);
  }
  EXPECT_GT(compared, 10000u) << what;
  // terracl keeps each split as a float: 1e-6 relative on the largest accumulations.
  EXPECT_LT(worst, 2e-6) << what << ": largest relative difference from the reference D-infinity";
}

}  // namespace

TEST(DinfReference, EqualsAnIndependentTarbotonOnAConeAndRealDems) {
  {
    const int n = 161;
    Heightfield cone(n, n, 0.f);
    cone.georef.cell_x = cone.georef.cell_y = 30.0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)  // apex off every cell centre: no two facets tie
        cone.at(x, y) = float(3000.0 - 30.0 * std::hypot(x - 80.37, y - 79.71));
    expect_same_as_reference(routed(cone), "cone");
  }
  expect_same_as_reference(routed(read_heightfield(test::data_path("crops/presidential_utm30_192.tif"))),
                           "30 m UTM crop");
  // Geographic: cells of about 66 x 93 m, so the facets' d1 != d2.
  const Heightfield geo = routed(read_heightfield(test::data_path("crops/presidential_128x96.tif")));
  ASSERT_GT(std::fabs(geo.georef.cell_x - geo.georef.cell_y), 10.0);
  expect_same_as_reference(geo, "SRTM crop in degrees");
}

TEST(DinfReference, InclinedPlanesCollectTheUpslopeLengthTimesTheFlowLineSpacing) {
  const int n = 121;
  for (const double deg : {0.0, 10.0, 22.5, 30.0, 45.0, 200.0, 300.0}) {
    // Flow direction t (counter-clockwise from east, y up = north); z falls along it.
    const double t = deg * M_PI / 180.0, ux = std::cos(t), uy = std::sin(t);
    Heightfield h(n, n, 0.f);
    h.georef.cell_x = h.georef.cell_y = 1.0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) h.at(x, y) = float(1000.0 - (x * ux - y * uy));  // row y grows southwards
    const analysis::DinfResult r = analysis::dinf_flow(h);
    const double spacing = std::max(std::fabs(ux), std::fabs(uy));
    std::vector<double> err;
    for (int y = 3; y < n - 3; ++y)
      for (int x = 3; x < n - 3; ++x) {
        // Upslope length: from the cell centre back along -t to the grid's edge (centres at
        // 0..n-1, edges half a cell beyond).
        double len = INFINITY;
        if (ux > 1e-12) len = std::min(len, (x + 0.5) / ux);
        if (ux < -1e-12) len = std::min(len, (n - 0.5 - x) / -ux);
        if (uy > 1e-12) len = std::min(len, (n - 0.5 - y) / uy);
        if (uy < -1e-12) len = std::min(len, (y + 0.5) / -uy);
        if (len < 30) continue;  // the edge row's half-cell staircase weighs ~1 / len
        const double exact = len * spacing;
        err.push_back(std::fabs(r.cells[size_t(y) * n + x] - exact) / exact);
      }
    ASSERT_GT(err.size(), 500u) << deg;
    // D-infinity spreads a plane's flow lines sideways (the 30-degree plane has a quarter of its
    // cells more than 10 % off, SAGA's alike), so the check is on the median.
    std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
    EXPECT_LT(err[err.size() / 2], 0.015) << deg << " degrees: median relative error";
    EXPECT_NEAR(r.outflow_cells, double(n) * n, 1e-6 * n * n) << deg << " degrees: every cell's water leaves";
  }
}
