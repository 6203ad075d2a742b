// SPDX-License-Identifier: Apache-2.0
// Drainage: stream-power channel incision (dendritic valleys carved from the terrain).
//
// On the current terrain h (a solve when stale): fill its depressions (Priority-Flood+epsilon,
// analysis/fill.cpp) and route flow on the filled surface (analysis/flow.cpp), over the whole grid
// so that a region's channels see the area draining into them from outside. `routing` "dinf" (the
// default) is Tarboton's D-infinity: the flow leaves each cell along its steepest facet, split
// between two neighbours, so channels follow the fall line in any direction; "d8" sends it all to
// one of the 8 neighbours, which on smooth slopes draws channels as straight runs along the axes
// and diagonals joined by kinks (a circuit-board pattern on a volcanic cone). Every cell whose
// contributing area A (cells x cell area) reaches `threshold` and lies in the region is a channel
// cell; its incision is the stream-power law
//     e = depth * (A / reference_area)^m * S^n       (capped at max_depth)
// S the slope to its receiver on the filled surface (D-infinity: the neighbour that takes the
// larger share). Each channel cell spreads its incision over
// a cross-section of half-width r = clamp(width * (A / reference_area)^width_exponent, 2 cells,
// max_width) with the smooth kernel (1 - (d / r)^2)^2 (the incision at a cell is the largest of its
// channels' kernels), the field is smoothed `smooth` times with a 3x3 binomial filter and weighted
// by the region (soft edge `falloff`).
//
// Drainage is kept by construction, in two steps. Grading: visited downstream first, each channel
// cell's cut is capped so that its bed stays at least 0.001 x the distance above its receiver's
// bed (cuts weighted by the region), so no bed rises downstream and a channel leaving the region
// is graded to the level where it leaves. Re-fill (the safety net, for overlapping
// cross-sections): the carved surface c = h - w e is filled again (Priority-Flood, no epsilon)
// and the result is min(h, fill(c)); min with h keeps the operation a pure incision (nothing is
// raised above the terrain, and the depressions h already had are left as they were).
//
// The change dz = result - h goes into the field like strata's: each face's gradient gains
// (dz_b - dz_a) / d; faces whose two cells did not change keep their bits, so the local solve and
// its locality work unchanged.
#include "authoring/state.hpp"

#include <terracl/amplify.hpp>  // row_parts, for_row_ranges
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <vector>

namespace terracl::edit {
namespace {

// A float's bits as an unsigned integer in the float's order (-0 as +0; no NaN).
uint32_t ordered_bits(float f) {
  f += 0.0f;
  uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}

// The smallest half-width of a channel's cross-section. The bowl kernel (1 - (d / r)^2)^2 is deeper
// than half the cut for d < 0.54 r: at r = 1.5 cells only the centre cell, so the smallest channels
// were 1-cell hairlines; at 2 cells the cells beside it too (3 cells, the narrowest channel the gallery asks for).
// The canyon section's floor keeps 1.5 cells: its walls widen it by 2 x depth / wall_slope anyway
// (and 2 cells there widened the canyon example's small side canyons onto its wall stations).
constexpr double kMinHalfWidthCells = 2.0, kMinCanyonFloorCells = 1.5;

struct DrainageParams {
  double depth = 0, a_ref = 0, a_min = 0, m = 0.5, n = 1.0;
  double width = 0, width_exp = 0.5, max_width = 0, max_depth = 0;
  int smooth = 1;
  bool dinf = true;  // D-infinity routing, else D8
  bool canyon = false;     // profile "canyon": a flat floor at the bed between walls of wall_slope
  double wall_slope = 1.5;  // (m per m)
  bool cut_rims = true;     // hard cells in the cut move down with it (else they stay: fins)
  double path_smooth = 0;   // canyon: channel centres averaged along the flow over +- this (m)
};

// The "canyon" cross-section: the carved surface is the lowest of the channels' sections, each a
// flat floor at its bed b_c (half-width r_c) with walls rising at `slope` beyond it:
//     T(p) = min_c ( b_c + slope * max(0, |p - c| - r_c) ),   result min(h, T).
// So a section's depth comes from the terrain (deep where the bed lies far below it, through a
// rim down a wall to the floor), its top width from its depth (floor + 2 depth / slope): a deep
// channel is a wide canyon, a shallow one a gully, and a head is a round amphitheatre. The floors
// are stamped as discs (the lowest bed wins); the walls are a weighted distance transform: two
// raster passes of a 5x5 chamfer mask (steps 1, sqrt 2, sqrt 5; within 2 % of the Euclidean cone,
// where a 3x3 mask's octagon, 8 % off, drew straight facets in the walls).
void carve_canyon_sections(const std::vector<float>& bed_field, int W, int H, double cx, double cy, double slope, std::vector<float>& t) {
  t = bed_field;
  struct Step {
    int dx, dy;
    float cost;
  };
  std::vector<Step> fwd;
  for (int dy = -2; dy <= 0; ++dy)
    for (int dx = -2; dx <= 2; ++dx) {
      if (dy == 0 && dx >= 0) continue;
      const int ax = std::abs(dx), ay = std::abs(dy);
      if ((ax == 2 && ay != 1) || (ay == 2 && ax != 1)) continue;  // (2,0), (2,2): sums of smaller steps
      fwd.push_back({dx, dy, float(slope * std::hypot(dx * cx, dy * cy))});
    }
  auto pass = [&](int sign) {
    for (int yy = 0; yy < H; ++yy) {
      const int y = sign > 0 ? yy : H - 1 - yy;
      for (int xx = 0; xx < W; ++xx) {
        const int x = sign > 0 ? xx : W - 1 - xx;
        float best = t[size_t(y) * W + x];
        for (const Step& s : fwd) {
          const int u = x + sign * s.dx, v = y + sign * s.dy;
          if (u < 0 || v < 0 || u >= W || v >= H) continue;
          best = std::fmin(best, t[size_t(v) * W + u] + s.cost);
        }
        t[size_t(y) * W + x] = best;
      }
    }
  };
  pass(1);
  pass(-1);
}

Operation parse_drainage(Params& p) {
  const Region r = parse_region(p, true);
  const Grid& grid = p.grid();
  const double cell = std::max(grid.cell_x, grid.cell_y), area = grid.cell_x * grid.cell_y;
  const double falloff = p.hlength("falloff", 4 * cell);
  DrainageParams dp;
  dp.depth = p.vlength("depth", 8 * cell);
  if (!(dp.depth > 0)) param_error(p.where("depth"), fmt::format("expected a depth > 0 m, got {:g}", dp.depth));
  dp.a_ref = p.number("reference_area", 1000 * area, 1e-300, 1e300);
  if (!(dp.a_ref > 0)) param_error(p.where("reference_area"), "expected an area > 0 m^2");
  dp.a_min = p.number("threshold", 100 * area, 0.0, 1e300);
  dp.m = p.number("m", 0.5, 0.0, 3.0);
  dp.n = p.number("n", 1.0, 0.0, 3.0);
  dp.width = p.hlength("channel_width", 3 * cell, 0, true);
  dp.width_exp = p.number("width_exponent", 0.5, 0.0, 1.0);
  dp.max_width = p.hlength("max_width", 10 * cell, 0, true);
  dp.max_depth = p.vlength("max_depth", 4 * dp.depth);
  if (!(dp.max_depth > 0)) param_error(p.where("max_depth"), fmt::format("expected a depth > 0 m, got {:g}", dp.max_depth));
  dp.smooth = p.integer("smooth", 1, 0, 20);
  dp.dinf = p.choice("routing", std::string("dinf"), {"dinf", "d8"}) == "dinf";
  dp.canyon = p.choice("profile", std::string("bowl"), {"bowl", "canyon"}) == "canyon";
  dp.wall_slope = p.number("wall_slope", 1.5, 0.05, 20.0);
  dp.cut_rims = p.boolean("cut_rims", true);
  dp.path_smooth = p.hlength("path_smooth", 0.0);
  // A max_width under the smallest half-width is raised to it, with a warning: a script in metres
  // written for fine cells must still run on a coarser grid (a preview, the oclgrind check's 80 m
  // cells), where refusing it made the whole script fail.
  const double min_half_width = (dp.canyon ? kMinCanyonFloorCells : kMinHalfWidthCells) * cell;
  if (dp.max_width < min_half_width) {
    if (p.grid().trace)
      p.grid().trace->warnings.push_back(fmt::format("{}: {:g} m is less than the smallest channel half-width here ({:g} cells, "
                                                     "{:g} m): channels are that wide",
                                                     p.where("max_width"), dp.max_width, min_half_width / cell, min_half_width));
    dp.max_width = min_half_width;
  }
  // The half-width reach of the widest channel: the support grows by it beyond the region (a
  // canyon's section reaches its floor plus its deepest wall).
  p.note_reach(dp.canyon ? dp.max_width + dp.max_depth / dp.wall_slope : dp.max_width);

  return [=](EditState& s) {
    GradientBuffers& b = s.buffers();
    const Heightfield& h = s.height();
    const auto t_start = std::chrono::steady_clock::now();
    const HostRegion reg = region_on_host(s, r, falloff);
    if (reg.box.empty()) return;
    const int W = b.width, H = b.height;
    const size_t N = size_t(W) * H;
    const double cx = b.cell_x, cy = b.cell_y, cell_area = cx * cy;
    auto w_region = [&](int x, int y) { return reg.weight(x, y); };

    // Flow on the filled terrain (whole grid).
    Heightfield hz = h;
    hz.georef.cell_x = cx, hz.georef.cell_y = cy;
    const analysis::FillResult filled = analysis::priority_flood_fill(hz, true);
    // D8 or D-infinity on the filled surface: every receiver is strictly lower, so the ascending
    // order of zf below is a topological order of either. `recv` is the neighbour (0..7) a cell
    // drains to (D-infinity: the one taking the larger share), or kOutlet / kNoFlow.
    std::vector<uint8_t> recv;
    std::vector<double> acc;
    if (dp.dinf) {
      analysis::DinfResult f = analysis::dinf_flow(filled.filled, {}, false);  // no angles needed
      recv.resize(N);
      for (size_t i = 0; i < N; ++i)
        recv[i] = (f.k2[i] < 8 && f.share1[i] < 0.5f) ? f.k2[i] : f.k1[i];
      acc = std::move(f.cells);
    } else {
      analysis::D8Result f = analysis::d8_flow(filled.filled);
      recv = std::move(f.dir);
      acc = std::move(f.cells);
    }
    const std::vector<float>& zf = filled.filled.z;
    double dist[8];
    for (int k = 0; k < 8; ++k)
      dist[k] = (analysis::kDx[k] != 0 && analysis::kDy[k] != 0) ? std::hypot(cx, cy) : (analysis::kDx[k] != 0 ? cx : cy);

    // Channel cells and their incision and half-width.
    std::vector<float> inc(N, 0.f);
    struct Channel {
      size_t i;
      double e, r;  // incision (m), half-width (m)
    };
    std::vector<Channel> ch;
    const double min_half_width = (dp.canyon ? kMinCanyonFloorCells : kMinHalfWidthCells) * std::max(cx, cy);
    const int rx_max = int(std::ceil(dp.max_width / cx)), ry_max = int(std::ceil(dp.max_width / cy));
    // Candidates row by row on every core (the per-cell powers are most of this pass: 435 k
    // candidates on a 1025^2 range), gathered in row order as one pass would list them.
    const size_t parts = row_parts(N, H);
    std::vector<std::vector<Channel>> part(parts);
    for_row_ranges(H, parts, [&](size_t t, int y0, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t i = size_t(y) * W + x;
          const double A = acc[i] * cell_area;
          if (!(A >= dp.a_min) || A <= 0 || w_region(x, y) <= 0) continue;
          const uint8_t k = recv[i];
          if (k == analysis::kNoFlow) continue;
          double S = 0;
          if (k < 8) {
            const size_t j = size_t(ptrdiff_t(i) + ptrdiff_t(analysis::kDy[k]) * W + analysis::kDx[k]);
            S = std::max(0.0, (double(zf[i]) - double(zf[j])) / dist[k]);
          } else {
            // An outlet (the grid's edge): the slope from its largest donor, so the channel is cut
            // through the edge instead of ending at a dam that the re-fill would flood back.
            double best = -1;
            for (int q = 0; q < 8; ++q) {
              const int u = x + analysis::kDx[q], v = y + analysis::kDy[q];
              if (u < 0 || v < 0 || u >= W || v >= H) continue;
              const size_t j = size_t(v) * W + u;
              const uint8_t kj = recv[j];
              if (kj >= 8 || u + analysis::kDx[kj] != x || v + analysis::kDy[kj] != y) continue;
              if (acc[j] > best) best = acc[j], S = std::max(0.0, (double(zf[j]) - double(zf[i])) / dist[q]);
            }
          }
          const double e = std::min(dp.max_depth, dp.depth * std::pow(A / dp.a_ref, dp.m) * (dp.n == 0 ? 1.0 : std::pow(S, dp.n)));
          if (!(e > 0)) continue;
          part[t].push_back({i, e, std::clamp(dp.width * std::pow(A / dp.a_ref, dp.width_exp), min_half_width, dp.max_width)});
        }
    });
    for (const auto& p : part) ch.insert(ch.end(), p.begin(), p.end());
    // Grading to base level: visited downstream first (the filled terrain's ascending order, a
    // topological order of the flow: every receiver is strictly lower), each channel cell's cut is
    // capped so that its bed lies at least kGrade x the distance above its receiver's bed, the
    // cuts weighted by the region (a receiver outside it, or not a channel, is not cut). So a bed
    // never rises downstream (where the slope drops faster than the area grows, or where the
    // region's soft edge crosses a channel), and the cut tapers to the level of the outflow
    // instead of being re-filled into a level reach.
    constexpr double kGrade = 1e-3;
    // Sorted by (zf, cell): ch is in cell order, so one 64-bit key per channel, its height's
    // order-preserving bits above its place in ch, sorts the same (a comparator reading zf through
    // the cell index took 50 ms for 400 k channels at 1025^2).
    {
      std::vector<uint64_t> key(ch.size());
      for (size_t q = 0; q < ch.size(); ++q) key[q] = (uint64_t(ordered_bits(zf[ch[q].i])) << 32) | uint64_t(q);
      std::sort(key.begin(), key.end());
      std::vector<Channel> sorted(ch.size());
      for (size_t q = 0; q < ch.size(); ++q) sorted[q] = ch[size_t(key[q] & 0xffffffffu)];
      ch.swap(sorted);
    }
    std::vector<int32_t> slot(N, -1);
    for (size_t q = 0; q < ch.size(); ++q) slot[ch[q].i] = int32_t(q);
    auto w_at = [&](size_t i) { return w_region(int(i % size_t(W)), int(i / size_t(W))); };
    double graded = 0;
    for (Channel& c : ch) {
      const uint8_t k = recv[c.i];
      if (k >= 8) continue;
      const size_t j = size_t(ptrdiff_t(c.i) + ptrdiff_t(analysis::kDy[k]) * W + analysis::kDx[k]);
      const double cut_j = slot[j] >= 0 ? w_at(j) * ch[size_t(slot[j])].e : 0.0;
      const double wi = w_at(c.i);
      const double cap = (cut_j + (double(zf[c.i]) - double(zf[j])) - kGrade * dist[k]) / wi;
      if (c.e > cap) graded = std::max(graded, c.e - std::max(0.0, cap)), c.e = std::max(0.0, cap);
    }
    size_t channels = 0;
    for (const Channel& c : ch) channels += c.e > 0;
    double deepest = 0, widest = 0;
    if (dp.canyon) {
      // Floors: each channel's bed (its graded cut, weighted by the region) stamped over a disc of
      // its half-width, the lowest winning; then the walls (carve_canyon_sections).
      constexpr float kHigh = 1e30f;
      std::vector<float> floor_z(N, kHigh), t;
      // Path smoothing: a channel's section is centred on the mean position of the cells within
      // +- path_smooth along its flow line (downstream by the receivers, upstream by the donor that
      // drains most), so the routing's steps between neighbours (D8's 0/45/90-degree zig-zags, the
      // receivers D-infinity picks) become the line's mean direction.
      const int k_path = int(std::lround(dp.path_smooth / std::max(cx, cy)));
      std::vector<size_t> main_donor;
      if (k_path > 0) {
        main_donor.assign(N, N);
        for (size_t i = 0; i < N; ++i) {
          const uint8_t k = recv[i];
          if (k >= 8) continue;
          const size_t j = size_t(ptrdiff_t(i) + ptrdiff_t(analysis::kDy[k]) * W + analysis::kDx[k]);
          if (main_donor[j] == N || acc[i] > acc[main_donor[j]] || (acc[i] == acc[main_donor[j]] && i < main_donor[j]))
            main_donor[j] = i;
        }
      }
      for (const Channel& c : ch) {
        if (!(c.e > 0)) continue;
        double x = double(c.i % size_t(W)), y = double(c.i / size_t(W));
        if (k_path > 0) {
          double sx = x, sy = y;
          int n = 1;
          size_t q = c.i;
          for (int k = 0; k < k_path && recv[q] < 8; ++k, ++n) {
            q = size_t(ptrdiff_t(q) + ptrdiff_t(analysis::kDy[recv[q]]) * W + analysis::kDx[recv[q]]);
            sx += double(q % size_t(W)), sy += double(q / size_t(W));
          }
          q = c.i;
          for (int k = 0; k < k_path && main_donor[q] != N; ++k, ++n) {
            q = main_donor[q];
            sx += double(q % size_t(W)), sy += double(q / size_t(W));
          }
          x = sx / n, y = sy / n;
        }
        deepest = std::max(deepest, c.e);
        widest = std::max(widest, c.r);
        const double bed = double(zf[c.i]) - w_at(c.i) * c.e;
        // (Stamped exactly, walls included, out to 2 cells past the floor's edge: seeded from the
        // floor's cells alone, the walls stood up to one cell x wall_slope too high, 1.2 m in the test.)
        const int rx = int(std::ceil(c.r / cx)) + 2, ry = int(std::ceil(c.r / cy)) + 2;
        const int xc = int(std::lround(x)), yc = int(std::lround(y));
        for (int v = std::max(0, yc - ry); v <= std::min(H - 1, yc + ry); ++v)
          for (int u = std::max(0, xc - rx); u <= std::min(W - 1, xc + rx); ++u) {
            const double d = std::hypot((u - x) * cx, (v - y) * cy);
            float& f = floor_z[size_t(v) * W + u];
            f = std::fmin(f, float(bed + dp.wall_slope * std::max(0.0, d - c.r)));
          }
      }
      carve_canyon_sections(floor_z, W, H, cx, cy, dp.wall_slope, t);
      for (size_t i = 0; i < N; ++i) inc[i] = std::fmax(0.f, h.z[i] - t[i]);
    } else {
      for (const Channel& c : ch) {
        const int x = int(c.i % size_t(W)), y = int(c.i / size_t(W));
        const double e = c.e, rw = c.r;
        if (!(e > 0)) continue;
        deepest = std::max(deepest, e);
        widest = std::max(widest, rw);
        const int rx = std::min(rx_max, int(std::ceil(rw / cx))), ry = std::min(ry_max, int(std::ceil(rw / cy)));
        for (int v = std::max(0, y - ry); v <= std::min(H - 1, y + ry); ++v)
          for (int u = std::max(0, x - rx); u <= std::min(W - 1, x + rx); ++u) {
            const double t2 = (std::pow((u - x) * cx, 2) + std::pow((v - y) * cy, 2)) / (rw * rw);
            if (t2 >= 1) continue;
            const float ek = float(e * (1 - t2) * (1 - t2));
            float& cc = inc[size_t(v) * W + u];
            cc = std::max(cc, ek);
          }
      }
    }
    // Smoothing (3x3 binomial), then the region's weight.
    std::vector<float> tmp(N);
    for (int pass = 0; pass < dp.smooth; ++pass) {
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const int xa = std::max(0, x - 1), xb = std::min(W - 1, x + 1);
          const size_t r0 = size_t(y) * W;
          tmp[r0 + x] = 0.25f * inc[r0 + xa] + 0.5f * inc[r0 + x] + 0.25f * inc[r0 + xb];
        }
      for (int y = 0; y < H; ++y) {
        const int ya = std::max(0, y - 1), yb = std::min(H - 1, y + 1);
        for (int x = 0; x < W; ++x)
          inc[size_t(y) * W + x] = 0.25f * tmp[size_t(ya) * W + x] + 0.5f * tmp[size_t(y) * W + x] + 0.25f * tmp[size_t(yb) * W + x];
      }
    }
    Heightfield carved = hz;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t i = size_t(y) * W + x;
        const double w = w_region(x, y);
        if (w > 0 && inc[i] > 0) carved.z[i] = float(double(hz.z[i]) - w * double(inc[i]));
      }
    // Keep every channel draining: re-fill the carved surface, never above the terrain.
    const analysis::FillResult refill = analysis::priority_flood_fill(carved, false);
    std::vector<double> dz(N, 0.0);
    double raised = 0;
    for (size_t i = 0; i < N; ++i) {
      const float z = std::min(h.z[i], refill.filled.z[i]);
      dz[i] = double(z) - double(h.z[i]);
      // What the re-fill raised above the carved surface, less what the base's own hollows needed
      // (zf, the terrain filled before the carve): those are left as they were and are not the
      // carve's doing (the report counted them, e.g. a closed basin under a mountain range's col).
      raised = std::max(raised, double(refill.filled.z[i]) - std::max(double(carved.z[i]), double(zf[i])));
    }
    GradientField g = s.download();
    size_t touched = 0;
    double max_cut = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t i = size_t(y) * W + x;
        max_cut = std::max(max_cut, -dz[i]);
        if (x + 1 < W && (dz[i] != 0 || dz[i + 1] != 0)) {
          g.gx[i] = float(g.gx[i] + (dz[i + 1] - dz[i]) / cx);
          ++touched;
        }
        if (y + 1 < H && (dz[i] != 0 || dz[i + W] != 0)) {
          g.gy[i] = float(g.gy[i] + (dz[i + W] - dz[i]) / cy);
          ++touched;
        }
      }
    s.upload(g);
    // Hard cells (a cliff's rim, a river's bed) that the cut reaches move down with it, as a
    // ravine's `cut_rims` releases them: pinned at their old elevation, a rim line left standing
    // across a side canyon's mouth is a fin (the solve holds it against the field's cut).
    size_t moved = 0;
    if (dp.cut_rims) {
      std::vector<float>& hard = s.hard();
      for (size_t i = 0; i < N; ++i)
        if (dz[i] != 0 && !std::isnan(hard[i])) hard[i] = float(double(hard[i]) + dz[i]), ++moved;
    }
    // The solve keeps the field's mean elevation when no cell is hard (a global solve): the mean
    // follows the incision, or the whole terrain would rise by the mean cut.
    double mean = 0;
    for (size_t i = 0; i < N; ++i) mean += double(h.z[i]) + dz[i];
    s.set_mean(mean / double(N));
    auto& log = s.log().back();
    log["channel_cells"] = channels;
    log["deepest_channel_m"] = deepest;
    log["widest_half_width_m"] = widest;
    log["max_incision_m"] = max_cut;
    log["graded_max_m"] = graded;
    log["refill_max_m"] = raised;
    log["faces"] = touched;
    log["hard_cells_moved"] = moved;
    log["drainage_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_start).count();
    s.changed();
  };
}

}  // namespace

void add_drainage_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"drainage",
                 "stream-power channel incision: carves a dendritic network of gullies and valleys along the terrain's own "
                 "drainage, deeper and wider where more area drains",
                 parse_drainage});
}

}  // namespace terracl::edit
