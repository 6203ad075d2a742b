// SPDX-License-Identifier: Apache-2.0
// Erosion in physical units: the suspended sediment settles back at the end so the output
// keeps all the material, and the defaults give the same result in metres whatever the cell size
// (the same terrain at SRTM3's ~80 m cells and upsampled 3x).
#include "test_helpers.hpp"

#include <terracl/erosion.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

using namespace terracl;

namespace {

double volume_m3(const Heightfield& h) {
  double v = 0;
  for (float z : h.z) v += z;
  return v * h.georef.cell_x * h.georef.cell_y;
}

}  // namespace

TEST(ErosionSettle, OutputKeepsAllTheMaterial) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const double a = dem.georef.cell_x * dem.georef.cell_y;
  ErosionParams p = ErosionParams::defaults();
  p.boundary = ErosionBoundary::Closed;  // nothing leaves: the output must hold all the input's material
  ErosionOutputs with, without;
  const Heightfield settled = erode(test::device(), dem, p, 300, nullptr, &with);
  p.settle = false;
  const Heightfield suspended = erode(test::device(), dem, p, 300, nullptr, &without);
  double moved = 0;
  for (size_t i = 0; i < dem.size(); ++i) moved += std::fabs(double(settled.z[i]) - dem.z[i]) * a;
  const double v0 = volume_m3(dem), drift = volume_m3(settled) - v0, lost = v0 - volume_m3(suspended);
  std::printf("volume moved %.4g m3; output - input: %.3g m3 settled, %.4g m3 without settling (suspended %.4g m3)\n",
              moved, drift, -lost, without.totals.sediment);
  ASSERT_GT(moved, 1e6) << "the run must move material for this test to mean anything";
  // Float32 beds of ~1000 m round at 6e-5 m per cell update: allow 1e-4 of the moved volume.
  EXPECT_LE(std::fabs(drift), 1e-4 * moved);
  // Without settling the output lost the suspended load (the old default): far above the bound.
  EXPECT_NEAR(lost, without.totals.sediment, 1e-3 * lost + 1e-4 * moved);
  EXPECT_GT(lost, 100 * 1e-4 * moved);
  EXPECT_NEAR(with.totals.settled, without.totals.sediment, 1e-3 * without.totals.sediment);
  EXPECT_LE(with.totals.sediment, 1e-6 * with.totals.settled);  // nothing left in suspension
  for (size_t i = 0; i < dem.size(); ++i) ASSERT_EQ(with.sediment.z[i], 0.0f);
  // The delta output includes the settled sediment.
  for (size_t i = 0; i < dem.size(); ++i) ASSERT_NEAR(with.delta.z[i], settled.z[i] - dem.z[i], 1e-4);
  // The default open border: what is not in the output left over the border, counted.
  ErosionOutputs open;
  const Heightfield drained = erode(test::device(), dem, ErosionParams::defaults(), 300, nullptr, &open);
  const double left = v0 - volume_m3(drained);
  std::printf("open border: output lost %.4g m3, drained sediment %.4g m3\n", left, open.totals.drained_sediment);
  EXPECT_GT(open.totals.drained_sediment, 1e-3 * moved) << "sediment must leave over the open border";
  EXPECT_NEAR(left, open.totals.drained_sediment, 1e-4 * moved);
}

TEST(ErosionSettle, BrushWeightZeroCellsStayFixed) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  std::vector<float> w(dem.size(), 1.0f);
  for (int y = 0; y < dem.height; ++y)
    for (int x = dem.width / 2; x < dem.width; ++x) w[size_t(y) * dem.width + x] = 0.0f;
  ErosionOutputs out;
  const Heightfield e = erode(test::device(), dem, ErosionParams::defaults(), 200, &w, &out);
  for (int y = 0; y < dem.height; ++y)
    for (int x = dem.width / 2; x < dem.width; ++x) ASSERT_EQ(e.at(x, y), dem.at(x, y)) << x << "," << y;
  EXPECT_GT(out.totals.settled, 0.0);
}

// The recession phase (docs/erosion.md, "The valley ribbon: recession phase and a depth-bounded
// pick-up"): after the rain the water drains for a while and carries its load along. It must keep
// the material (closed border), count what leaves (open border), stop the rain, and move load out
// that the plain run leaves to settle in place.
TEST(ErosionRecession, DrainsTheLoadAndKeepsTheMaterial) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const double a = dem.georef.cell_x * dem.georef.cell_y;
  ErosionParams p = ErosionParams::defaults();
  p.recession = 0;
  p.boundary = ErosionBoundary::Closed;
  ErosionParams r = p;
  r.recession = 100;
  r.recession_evaporation = 0.02;
  {
    Erosion sim(test::device(), dem, r);
    EXPECT_EQ(sim.recession_steps(), int(std::ceil(100 / sim.step_dt() - 1e-9)));
  }
  ErosionOutputs plain, closed;
  erode(test::device(), dem, p, 200, nullptr, &plain);
  const Heightfield kept = erode(test::device(), dem, r, 200, nullptr, &closed);
  double moved = 0;
  for (size_t i = 0; i < dem.size(); ++i) moved += std::fabs(double(kept.z[i]) - dem.z[i]) * a;
  const double drift = volume_m3(kept) - volume_m3(dem);
  std::printf("recession, closed border: moved %.4g m3, output - input %.3g m3; rained %.4g m3 (plain %.4g)\n", moved,
              drift, closed.totals.rained, plain.totals.rained);
  ASSERT_GT(moved, 1e6);
  EXPECT_LE(std::fabs(drift), 1e-4 * moved);
  EXPECT_DOUBLE_EQ(closed.totals.rained, plain.totals.rained) << "no rain in the recession";
  // Open border: the recession drains load that the plain run settles in place, and counts it.
  p.boundary = r.boundary = ErosionBoundary::Open;
  ErosionOutputs open_plain, open_rec;
  const Heightfield a0 = erode(test::device(), dem, p, 200, nullptr, &open_plain);
  const Heightfield a1 = erode(test::device(), dem, r, 200, nullptr, &open_rec);
  std::printf("open border: drained sediment %.4g m3 plain, %.4g m3 with the recession\n",
              open_plain.totals.drained_sediment, open_rec.totals.drained_sediment);
  EXPECT_GT(open_rec.totals.drained_sediment, 1.05 * open_plain.totals.drained_sediment);
  EXPECT_NEAR(volume_m3(dem) - volume_m3(a1), open_rec.totals.drained_sediment, 1e-4 * moved);
  EXPECT_NE(a0.z, a1.z);
  // Out-of-range recession parameters are errors naming them.
  r.recession = -1;
  try {
    erode(test::device(), dem, r, 1);
    ADD_FAILURE() << "a negative recession ran";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("recession"), std::string::npos) << e.what();
  }
}

// max_concentration bounds the pick-up by the water depth (docs/erosion.md, same section): the load
// per metre of water ends far below the unbounded run's, and the bed moves less.
TEST(ErosionRecession, MaxConcentrationBoundsTheLoadPerDepth) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  auto run = [&](double c) {
    ErosionParams p = ErosionParams::defaults();
    p.boundary = ErosionBoundary::Closed;
    p.settle = false;
    p.max_concentration = c;
    // Any flow picks up (no critical shear): the default's 200 Pa leaves the sheet flow clear and
    // the 99th percentile of sediment/depth at 2.5, too close to the bound of 2 to test it.
    p.critical_shear = 0;
    ErosionOutputs out;
    const Heightfield bed = erode(test::device(), dem, p, 150, nullptr, &out);
    std::vector<double> ratio;
    for (size_t i = 0; i < dem.size(); ++i)
      if (out.water.z[i] > 0.05f) ratio.push_back(double(out.sediment.z[i]) / out.water.z[i]);
    std::sort(ratio.begin(), ratio.end());
    double moved = 0;
    for (size_t i = 0; i < dem.size(); ++i) moved += std::fabs(double(bed.z[i]) - dem.z[i]);
    return std::pair<double, double>(ratio.empty() ? 0.0 : ratio[ratio.size() * 99 / 100], moved / dem.size());
  };
  const auto [free_ratio, free_moved] = run(0);
  const auto [bound_ratio, bound_moved] = run(2);
  std::printf("99th pct of sediment/depth: %.3g unbounded, %.3g with max_concentration 2; "
              "mean |change| %.3g -> %.3g m\n",
              free_ratio, bound_ratio, free_moved, bound_moved);
  EXPECT_GT(free_ratio, 4.0) << "the unbounded run must carry more than the bound for this test to mean anything";
  EXPECT_LT(bound_ratio, 0.5 * free_ratio);
  EXPECT_LT(bound_moved, free_moved);
}

namespace {

/// Catmull-Rom upsampling by an integer factor (cell centres aligned, clamped border): the same
/// terrain on a finer grid, as `gdalwarp -r cubic -ts` makes it.
Heightfield upsample(const Heightfield& h, int k) {
  Heightfield out(h.width * k, h.height * k);
  out.georef = h.georef;
  out.georef.cell_x = h.georef.cell_x / k;
  out.georef.cell_y = h.georef.cell_y / k;
  auto at = [&](int x, int y) { return double(h.at(std::clamp(x, 0, h.width - 1), std::clamp(y, 0, h.height - 1))); };
  auto cr = [](double p0, double p1, double p2, double p3, double t) {
    return p1 + 0.5 * t * (p2 - p0 + t * (2 * p0 - 5 * p1 + 4 * p2 - p3 + t * (3 * (p1 - p2) + p3 - p0)));
  };
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const double fx = (x + 0.5) / k - 0.5, fy = (y + 0.5) / k - 0.5;
      const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
      const double tx = fx - x0, ty = fy - y0;
      double row[4];
      for (int j = -1; j <= 2; ++j)
        row[j + 1] = cr(at(x0 - 1, y0 + j), at(x0, y0 + j), at(x0 + 1, y0 + j), at(x0 + 2, y0 + j), tx);
      out.at(x, y) = float(cr(row[0], row[1], row[2], row[3], ty));
    }
  return out;
}

double mean_abs_change(const Heightfield& a, const Heightfield& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += std::fabs(double(b.z[i]) - a.z[i]);
  return s / double(a.size());
}

double eroded_metres(const Heightfield& h, const ErosionParams& p, int steps) {
  return mean_abs_change(h, erode(test::device(), h, p, steps));
}

}  // namespace

// The defaults are physical: 400 s on the same terrain at SRTM3 cells (~80 m) and upsampled 3x
// (~27 m) move about the same metres of material. With the old pipe area (= cell area) and the
// old default of 400 steps the fine grid eroded far less.
TEST(ErosionScale, DefaultsGiveTheSameErosionAtAnyCellSize) {
  Heightfield coarse = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  {  // a 48 x 36 window keeps the fine run small
    Heightfield w(48, 36);
    w.georef = coarse.georef;
    for (int y = 0; y < 36; ++y)
      for (int x = 0; x < 48; ++x) w.at(x, y) = coarse.at(40 + x, 30 + y);
    coarse = w;
  }
  const Heightfield fine = upsample(coarse, 3);
  const ErosionParams p = ErosionParams::defaults();
  auto steps_for = [&](const Heightfield& h, const ErosionParams& q, double seconds) {
    const double dt = 0.5 * erosion_stability_limit(q, h.georef.cell_x, h.georef.cell_y);
    return int(std::ceil(seconds / dt));
  };
  const double m_coarse = eroded_metres(coarse, p, steps_for(coarse, p, 400));
  const double m_fine = eroded_metres(fine, p, steps_for(fine, p, 400));
  ErosionParams old = p;
  old.pipe_area = coarse.georef.cell_x * coarse.georef.cell_y / 9;  // the fine grid's cell area
  const double m_fine_old = eroded_metres(fine, old, 400);
  std::printf("mean |bed change| over 400 s: %.2f m at %.0f m cells, %.2f m at %.0f m cells; old defaults on the "
              "fine grid %.2f m\n",
              m_coarse, std::sqrt(coarse.georef.cell_x * coarse.georef.cell_y), m_fine,
              std::sqrt(fine.georef.cell_x * fine.georef.cell_y), m_fine_old);
  // 0.73 m at 78 m cells, 0.81 m at 26 m: the critical shear leaves the hillslopes' sheet flow
  // uncut (before it, 2.3 m), and the in-transit load refills the carved trunks.
  EXPECT_GT(m_coarse, 0.5);
  EXPECT_NEAR(m_fine / m_coarse, 1.0, 0.3);
  EXPECT_FALSE(std::fabs(m_fine_old / m_coarse - 1.0) < 0.3) << "the old defaults were not scale-independent";
}

namespace {

/// Cross-section floor widths (cells) of the channels carved into `eroded`: at every cell that is a
/// strict minimum of the bed across x (or y) and lies at least 1 m below the input, the run of cells
/// along that axis whose concave-up curvature (second difference) is at least half the centre's.
/// A V-shaped one-cell notch has width 1; a rounded channel floor several cells.
std::vector<int> channel_floor_widths(const Heightfield& input, const Heightfield& eroded) {
  std::vector<int> widths;
  const int W = eroded.width, H = eroded.height;
  for (const auto [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
    auto curv = [&](int x, int y) {
      return double(eroded.at(x - dx, y - dy)) + eroded.at(x + dx, y + dy) - 2.0 * eroded.at(x, y);
    };
    for (int y = 1; y < H - 1; ++y)
      for (int x = 1; x < W - 1; ++x) {
        const float c = eroded.at(x, y);
        if (!(c < eroded.at(x - dx, y - dy) && c < eroded.at(x + dx, y + dy)) || input.at(x, y) - c < 1.0f) continue;
        const double half = 0.5 * curv(x, y);
        int n = 1;
        for (int s : {-1, 1})
          for (int k = 1;; ++k) {
            const int xk = x + s * k * dx, yk = y + s * k * dy;
            if (xk < 1 || yk < 1 || xk >= W - 1 || yk >= H - 1 || curv(xk, yk) < half) break;
            ++n;
          }
        widths.push_back(n);
      }
  }
  return widths;
}

}  // namespace

// Issue 15: at ~10 m cells the default channels were one-cell V notches (a dark line with a bright
// wall in the hillshade). The channel diffusion (K_q * unit discharge) rounds their floors over
// several cells; without it (K_q = 0, the defaults before) most channel floors are one cell wide.
TEST(ErosionScale, ChannelsAreSeveralCellsWideAtTenMetres) {
  const Heightfield srtm = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  Heightfield window(24, 18);
  window.georef = srtm.georef;
  for (int y = 0; y < 18; ++y)
    for (int x = 0; x < 24; ++x) window.at(x, y) = srtm.at(40 + x, 30 + y);
  const Heightfield fine = upsample(window, 7);  // 168 x 126 cells of ~9.5 x 13 m
  auto run = [&](double kq) {
    ErosionParams p = ErosionParams::defaults();
    p.channel_diffusion = kq;
    const double dt = 0.5 * erosion_stability_limit(p, fine.georef.cell_x, fine.georef.cell_y);
    const std::vector<int> w = channel_floor_widths(fine, erode(test::device(), fine, p, int(std::ceil(400.0 / dt))));
    const double one = double(std::count(w.begin(), w.end(), 1)) / std::max<size_t>(1, w.size());
    double mean = 0;
    for (int v : w) mean += v;
    return std::tuple{w.size(), one, mean / std::max<size_t>(1, w.size())};
  };
  const auto [n_new, one_new, mean_new] = run(ErosionParams::defaults().channel_diffusion);
  const auto [n_old, one_old, mean_old] = run(0.0);
  std::printf("channel floors at %.1f x %.1f m cells: defaults %zu, %.1f %% one cell wide, mean %.2f cells; "
              "without channel diffusion %zu, %.1f %%, mean %.2f cells\n",
              fine.georef.cell_x, fine.georef.cell_y, n_new, 100 * one_new, mean_new, n_old, 100 * one_old, mean_old);
  // With the critical shear only the concentrated flow cuts, so fewer floors are carved >= 1 m than
  // before it (76 against 300-odd; without channel diffusion 241 narrower ones): defaults 54 % one
  // cell wide, mean 2.01 cells; without channel diffusion 62 %, mean 1.46 cells.
  ASSERT_GT(n_new, 40u) << "the run must carve channels for this test to mean anything";
  EXPECT_GT(one_old, 0.6) << "without channel diffusion the floors are one-cell notches";
  EXPECT_LT(one_new, one_old);
  EXPECT_GT(mean_new, mean_old + 0.4);
}

namespace {

struct Ribbon {
  double raised = 0;  ///< share of the valley floors raised more than 1 m above the input
  double p95 = 0;     ///< 95th percentile of their raise (m)
  double carved = 0;  ///< mean lowering over the whole grid (m): the carving, whatever settles
};

/// The valley ribbon of scripts/erosion-look.py: on the cells whose D8 area on the input is at least
/// 0.5 km^2, how many the run leaves more than 1 m above the input.
Ribbon ribbon(const Heightfield& input, const Heightfield& out) {
  const std::vector<double> area = test::d8_area(input, input.georef.cell_x * input.georef.cell_y);
  std::vector<double> raise;
  Ribbon r;
  for (size_t i = 0; i < input.size(); ++i) {
    const double d = double(out.z[i]) - input.z[i];
    r.carved += std::max(0.0, -d) / double(input.size());
    if (area[i] >= 0.5e6) raise.push_back(d);
  }
  if (raise.empty()) return r;
  r.raised = double(std::count_if(raise.begin(), raise.end(), [](double d) { return d > 1.0; })) / raise.size();
  std::sort(raise.begin(), raise.end());
  r.p95 = raise[std::min(raise.size() - 1, size_t(0.95 * double(raise.size() - 1) + 0.5))];
  return r;
}

}  // namespace

// Issue 15, the valley ribbon: with the old damped pipes (0.5 /s), evaporation 0.02 /s and pick-up
// 0.015 /s the load of 400 s of gullying stopped in the trunk valleys and settled there, 1 m to tens
// of metres above the input floor. The defaults carry it on and out of the crop and keep the carving.
TEST(ErosionSettle, DefaultsLeaveNoRaisedValleyRibbon) {
  const Heightfield dem = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const ErosionParams p = ErosionParams::defaults();
  ErosionParams old = p;
  old.damping = 0.5, old.evaporation = 0.02, old.dissolve = 0.015;
  // And the physics before "Does it read as nature" (docs/erosion.md) as far as it can be switched
  // back: no critical shear, thermal erosion everywhere, the creep of then, and the suspended load
  // settled where it stands (settle_sediment) instead of run on down the valleys (route_sediment).
  old.critical_shear = 0, old.thermal_banks_only = false, old.diffusion = 2, old.channel_diffusion = 1;
  old.settle = false;
  const auto steps = [&](const ErosionParams& q) {
    return int(std::ceil(400.0 / (0.5 * erosion_stability_limit(q, dem.georef.cell_x, dem.georef.cell_y))));
  };
  const Ribbon now = ribbon(dem, erode(test::device(), dem, p, steps(p)));
  ErosionOutputs old_out;
  Heightfield old_bed = erode(test::device(), dem, old, steps(old), nullptr, &old_out);
  std::vector<float> no_deposit;
  settle_sediment(old_bed, old_out.sediment.z, no_deposit, nullptr);
  const Ribbon before = ribbon(dem, old_bed);
  std::printf("valley floors raised > 1 m: %.1f %% (95th pct %+.1f m), old defaults %.1f %% (%+.1f m); "
              "mean carving %.2f m, old %.2f m\n",
              100 * now.raised, now.p95, 100 * before.raised, before.p95, now.carved, before.carved);
  ASSERT_GT(before.raised, 0.15) << "the old defaults must show the ribbon for this test to mean anything";
  EXPECT_LT(now.raised, 0.5 * before.raised);
  EXPECT_LT(now.p95, 0.5 * before.p95);
  // The critical shear leaves the sheet flow of the hillslopes uncut, so the mean lowering is about
  // half the old one (1.69 m against 2.95-3.47 m); ErosionLook checks that the channels still cut.
  EXPECT_GT(now.carved, 0.4 * before.carved) << "the ribbon must not go by carving nothing";
}
