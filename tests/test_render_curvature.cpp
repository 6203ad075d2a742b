// SPDX-License-Identifier: Apache-2.0
// render --mode profile-curvature|tangential-curvature: GRASS r.slope.aspect's pcurvature and
// tcurvature, on the host (double) and the device (float). Checked against the exact curvature of a
// quadratic (Horn's gradient and the fitted second derivatives are exact there) and against GRASS
// 8.2's own output on a real DEM (data/anchors, scripts/make-anchors.sh).
#include "test_helpers.hpp"

#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include <cmath>

using namespace terracl;

namespace {

render::Options curvature_options(bool profile) {
  render::Options o;
  o.mode = profile ? render::Mode::ProfileCurvature : render::Mode::TangentialCurvature;
  o.compute_edges = false;
  return o;
}

}  // namespace

TEST(RenderCurvature, ExactOnAParabolicTrough) {
  // z = a x^2 (x east, metres): a trough along y. With GRASS's signs (minus the derivatives along
  // east and north), its profile curvature is -2a / (1 + (2ax)^2)^1.5 and it has no tangential one.
  const int w = 60, h = 40;
  const double cell = 10.0, a = 2e-3;
  Heightfield z(w, h);
  z.georef.cell_x = z.georef.cell_y = cell;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double xm = (x - 20.5) * cell;
      z.at(x, y) = float(1000.0 + a * xm * xm);
    }
  const Heightfield pc = render::values(z, curvature_options(true)), tc = render::values(z, curvature_options(false));
  const Heightfield pcd = render::values(z, curvature_options(true), test::device());
  const Heightfield tcd = render::values(z, curvature_options(false), test::device());
  int checked = 0;
  for (int y = 1; y < h - 1; ++y)
    for (int x = 1; x < w - 1; ++x) {
      const double xm = (x - 20.5) * cell, g = 2 * a * xm;
      const double exact = -2 * a / std::pow(1 + g * g, 1.5);
      // float elevations near 1000 m: second differences carry ~1e-4 m of rounding over 100 m^2
      EXPECT_NEAR(pc.at(x, y), exact, 2e-6) << x << "," << y;
      EXPECT_NEAR(tc.at(x, y), 0.0, 2e-6) << x << "," << y;
      EXPECT_NEAR(pcd.at(x, y), exact, 2e-5) << x << "," << y;
      EXPECT_NEAR(tcd.at(x, y), 0.0, 2e-5) << x << "," << y;
      ++checked;
    }
  EXPECT_EQ(checked, (w - 2) * (h - 2));
  EXPECT_TRUE(std::isnan(pc.at(0, 5)));  // the border, as gdaldem's and GRASS's (without -e)
  EXPECT_EQ(pc.georef.vertical_units, "1/m");
}

TEST(RenderCurvature, EqualsGrassRSlopeAspectOnARealDem) {
  // GRASS ran on the 64 x 64 window at (64, 64) of the crop; its border is null there, and inside
  // the window every 3 x 3 neighbourhood is the same as in the whole crop.
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_utm30_192.tif"));
  for (const bool profile : {true, false}) {
    const Heightfield grass =
        read_heightfield(test::data_path(profile ? "anchors/grass_pcurvature_64.tif" : "anchors/grass_tcurvature_64.tif"));
    ASSERT_EQ(grass.width, 64);
    const Heightfield host = render::values(dem, curvature_options(profile));
    const Heightfield dev = render::values(dem, curvature_options(profile), test::device());
    double largest = 0;
    int compared = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const float g = grass.at(x, y);
        if (std::isnan(g)) {
          EXPECT_TRUE(x == 0 || y == 0 || x == 63 || y == 63) << x << "," << y;
          continue;
        }
        largest = std::max(largest, double(std::fabs(g)));
        // GRASS stores float32 of its double result: the host's double equals it to float rounding
        EXPECT_NEAR(host.at(64 + x, 64 + y), g, 1e-7 * std::fabs(g) + 1e-12) << profile << " " << x << "," << y;
        EXPECT_NEAR(dev.at(64 + x, 64 + y), g, 1e-8) << profile << " " << x << "," << y;
        ++compared;
      }
    EXPECT_EQ(compared, 62 * 62);
    EXPECT_GT(largest, 1e-3) << "a real curvature range (1/m)";
  }
}
