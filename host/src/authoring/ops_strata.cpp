// SPDX-License-Identifier: Apache-2.0
// Strata: layered rock of alternating hardness inside a region (canyon and cliff walls).
//
// The stack is a monotone map S of elevations (metres in -> metres out) built from the top down:
// pairs of a hard layer over a soft one, their thicknesses (as they appear in the result) jittered
// per layer. Within a pair S is linear in two pieces, steep (factor f_hard) through the hard layer
// and gentle (f_soft = f_hard / contrast) through the soft one, and S is the identity at every
// pair's boundaries, so the stack neither lifts nor sinks the terrain as a whole.
//
// Gradient form (default): the terrain's slope at every steep face inside the region is scaled by
// the secant slope (S(h1) - S(h0)) / (h1 - h0) of the stack between the elevations of its two cells
// (the discrete chain rule): the face's gradient gains w (S(h1) - S(h0) - (h1 - h0)) / d, w the
// region's weight times a slope weight (0 below min_slope). Where w is 1 the reconstruction moves
// by exactly S(h) - h: hard layers become risers, soft layers benches; where w fades (gentle
// slopes, the region's edge) the Poisson solve spreads the mismatch smoothly. The change is taken
// from the terrain h (the current reconstruction), not from the field's own gradient: on a canyon
// wall between a pinned rim and a pinned river the field explains only part of the drop (the solve
// adds the rest as a harmonic correction), and scaling the field alone diluted the steps ~3x.
// Dip and undulation: the beds need not be level. At a cell p the stack is read at h - o(p) and
// shifted back, S_o(h) = S(h - o) + o, with o(p) = -tan(dip) (p . u) + undulation n(p): a plane
// falling towards `dip_direction` plus a smooth seeded wave field n (three plane waves, |n| <= 1).
// Level beds ring every wall at one elevation like a contour model; real beds dip a little and
// warp, so the bands climb and fall along a wall and cross its contours.
// Remap form ("form": "remap", kept for comparison): g += grad(w (S(h) - h)), the elevation remap
// blended by the weight: the same where w is constant, plus (S(h) - h) grad(w), which draws bumps
// along the weight's contours (the foot and brink of every wall): why it is not the default.
#include "authoring/state.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <vector>

namespace terracl::edit {
namespace {

constexpr size_t kMaxPairs = 100000;
constexpr double kPi = 3.14159265358979323846;

double smoother01(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * t * (t * (t * 6 - 15) + 10);
}

// A uniform number in [-1, 1] for layer `k` of stack `seed` (splitmix64: the same on every platform,
// unlike std:: distributions).
double jitter_unit(unsigned seed, uint64_t k) {
  uint64_t z = (uint64_t(seed) << 32) ^ (k + 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return double(z >> 11) / double(1ull << 52) * 2.0 - 1.0;
}

struct StrataParams {
  double top = 0, bottom = -INFINITY;
  double hard = 0, soft = 0;  // mean thicknesses (m) of the hard and soft layers in the result
  double jitter = 0, contrast = 1;
  unsigned seed = 1;
  double dip_tan = 0, dip_ux = 1, dip_uy = 0;  // tan(dip); the dip direction in the grid frame
  double undulation = 0, wavelength = 1;     // amplitude (m) and wavelength (m) of the wave field
  /// o(p): the beds' elevation offset at (x, y) metres.
  double offset(double x, double y) const {
    double o = -dip_tan * (x * dip_ux + y * dip_uy);
    if (undulation > 0) {
      double n = 0;
      static constexpr double kScale[3] = {1.0, 0.62, 0.38}, kAmp[3] = {1.0, 0.5, 0.25};
      for (int k = 0; k < 3; ++k) {
        const double a = 3.14159265358979323846 * (1 + jitter_unit(seed ^ 0x5eedu, uint64_t(3 * k)));
        const double ph = 3.14159265358979323846 * jitter_unit(seed ^ 0x5eedu, uint64_t(3 * k + 1));
        const double kw = 2 * 3.14159265358979323846 / (wavelength * kScale[k]);
        n += kAmp[k] * std::sin(kw * (x * std::cos(a) + y * std::sin(a)) + ph);
      }
      o += undulation * n / 1.75;
    }
    return o;
  }
  bool level() const { return dip_tan == 0 && undulation == 0; }
};

struct Pair {
  double lo, hi;     // the pair's elevations (S(lo) = lo, S(hi) = hi)
  double split_in;   // input elevation of the soft/hard boundary
  double soft_out;   // its output elevation: lo + soft thickness
  double f_soft, f_hard;
};

/// The layer stack from `top` down to the first pair boundary at or below `zmin` (or `bottom`).
class Stack {
 public:
  Stack(const StrataParams& p, double zmin) {
    double z = p.top;
    const double stop = std::max(zmin, p.bottom);
    for (uint64_t k = 0; z > stop; ++k) {
      if (k >= kMaxPairs)
        throw Error("edit", fmt::format("strata: more than {} layer pairs between {:g} m and {:g} m (thickness too small)",
                                kMaxPairs, p.top, stop));
      const double th = p.hard * (1 + p.jitter * jitter_unit(p.seed, 2 * k));
      const double ts = p.soft * (1 + p.jitter * jitter_unit(p.seed, 2 * k + 1));
      const double lo = z - th - ts;
      if (lo < p.bottom) break;
      Pair q;
      q.lo = lo;
      q.hi = z;
      q.f_soft = (ts + th / p.contrast) / (th + ts);
      q.f_hard = p.contrast * q.f_soft;
      q.split_in = lo + ts / q.f_soft;
      q.soft_out = lo + ts;
      m_pairs.push_back(q);
      z = lo;
    }
  }
  /// S(z): the elevation z moves to (identity outside the stack).
  double map(double z) const {
    const Pair* q = find(z);
    if (!q) return z;
    return z <= q->split_in ? q->lo + q->f_soft * (z - q->lo) : q->soft_out + q->f_hard * (z - q->split_in);
  }
  const std::vector<Pair>& pairs() const { return m_pairs; }

 private:
  const Pair* find(double z) const {
    if (m_pairs.empty() || z > m_pairs.front().hi || z < m_pairs.back().lo) return nullptr;
    // Pairs run downward: the first pair whose lo is <= z.
    auto it = std::partition_point(m_pairs.begin(), m_pairs.end(), [z](const Pair& q) { return q.lo > z; });
    return it == m_pairs.end() ? nullptr : &*it;
  }
  std::vector<Pair> m_pairs;
};

double polygon_area(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += (p[j].x - p[i].x) * (p[j].y + p[i].y);
  return 0.5 * std::abs(a);
}

Operation parse_strata(Params& p) {
  const Region r = parse_region(p, false);
  if (r.kind == Region::Polygon && !(polygon_area(r.polygon) > 0))
    param_error(p.where("polygon"), "the polygon encloses no area (an empty region)");
  const Grid& grid = p.grid();
  const double falloff = p.hlength("falloff", 4 * std::max(grid.cell_x, grid.cell_y));
  StrataParams sp;
  sp.top = p.vlength("top");
  sp.hard = p.vlength("thickness");
  if (!(sp.hard > 0)) param_error(p.where("thickness"), fmt::format("expected a thickness > 0 m, got {:g}", sp.hard));
  sp.soft = p.vlength("soft_thickness", 0.5 * sp.hard);
  if (!(sp.soft > 0)) param_error(p.where("soft_thickness"), fmt::format("expected a thickness > 0 m, got {:g}", sp.soft));
  if (p.has("bottom")) {
    sp.bottom = p.vlength("bottom");
    if (!(sp.bottom < sp.top)) param_error(p.where("bottom"), fmt::format("expected an elevation below top ({:g} m), got {:g}", sp.top, sp.bottom));
    if ((sp.top - sp.bottom) / (sp.hard + sp.soft) > double(kMaxPairs))
      param_error(p.where("thickness"), fmt::format("more than {} layer pairs between bottom and top", kMaxPairs));
  }
  sp.jitter = p.number("jitter", 0.3, 0.0, 0.9);
  sp.contrast = p.number("contrast", 6.0, 1.0, 100.0);
  sp.seed = unsigned(p.integer("seed", int(grid.seed % 1000000007u), 0, 2147483647));
  const double min_slope = p.angle("min_slope", 20.0);
  const double ramp = p.angle("slope_ramp", 10.0);
  if (!(min_slope >= 0 && min_slope < 0.5 * kPi)) param_error(p.where("min_slope"), "expected an angle in [0, 90) degrees");
  if (!(ramp >= 0)) param_error(p.where("slope_ramp"), "expected an angle >= 0 degrees");
  const bool remap = p.choice("form", "gradient", {"gradient", "remap"}) == "remap";
  const double dip = p.angle("dip", 0.0);
  if (!(dip >= 0 && dip < 0.25 * kPi)) param_error(p.where("dip"), "expected an angle in [0, 45) degrees");
  sp.dip_tan = std::tan(dip);
  const double dip_dir = grid_angle(p.angle("dip_direction", 0.0));
  sp.dip_ux = std::cos(dip_dir), sp.dip_uy = std::sin(dip_dir);
  sp.undulation = p.vlength("undulation", 0.0);
  if (!(sp.undulation >= 0)) param_error(p.where("undulation"), fmt::format("expected an amplitude >= 0 m, got {:g}", sp.undulation));
  sp.wavelength = p.hlength("undulation_wavelength", 2000.0);
  const double t0 = std::tan(min_slope), t1 = std::tan(std::min(min_slope + ramp, 0.4999 * kPi));

  return [=](EditState& s) {
    GradientBuffers& b = s.buffers();
    const Heightfield& h = s.height();  // the elevations the layers are read at (a solve when stale)
    const auto t_start = std::chrono::steady_clock::now();
    const HostRegion reg = region_on_host(s, r, falloff);
    if (reg.box.empty()) return;
    const Box& box = reg.box;
    const std::vector<float>& wr = reg.w;
    const int W = b.width, H = b.height;
    // The beds' offset at each cell of the box (0 for level beds), and the lowest h - o the stack
    // must reach.
    std::vector<double> off(size_t(box.w) * box.h, 0.0);
    if (!sp.level())
      for (int y = 0; y < box.h; ++y)
        for (int x = 0; x < box.w; ++x) off[size_t(y) * box.w + x] = sp.offset((box.x0 + x) * b.cell_x, (box.y0 + y) * b.cell_y);
    double zmin = INFINITY;
    for (int y = 0; y < box.h; ++y)
      for (int x = 0; x < box.w; ++x)
        if (wr[size_t(y) * box.w + x] > 0) zmin = std::min(zmin, double(h.z[size_t(box.y0 + y) * W + box.x0 + x]) - off[size_t(y) * box.w + x]);
    const Stack stack(sp, std::isfinite(zmin) ? double(zmin) - 1.0 : sp.top);
    GradientField g = s.download();
    auto in_box = [&](int x, int y) { return reg.contains(x, y); };
    auto w_region = [&](int x, int y) { return reg.weight(x, y); };
    auto w_slope = [&](double slope) { return t1 > t0 ? smoother01((slope - t0) / (t1 - t0)) : (slope >= t0 ? 1.0 : 0.0); };
    // The terrain's slope at each cell of the box (central differences, one-sided at the map's
    // border): the slope the layers meet, whatever the field holds (hard constraints may have bent
    // the reconstruction away from it).
    auto z = [&](int x, int y) { return double(h.z[size_t(y) * W + x]); };
    // S_o at a cell of the box: the stack read at h - o and shifted back.
    auto layered = [&](int x, int y) {
      const double o = in_box(x, y) ? off[size_t(y - box.y0) * box.w + (x - box.x0)]
                                    : (sp.level() ? 0.0 : sp.offset(x * b.cell_x, y * b.cell_y));
      return stack.map(z(x, y) - o) + o;
    };
    std::vector<double> cs(size_t(box.w) * box.h);
    for (int y = box.y0; y < box.y0 + box.h; ++y)
      for (int x = box.x0; x < box.x0 + box.w; ++x) {
        const int xa = std::max(0, x - 1), xb = std::min(W - 1, x + 1), ya = std::max(0, y - 1), yb = std::min(H - 1, y + 1);
        const double sx = xb > xa ? (z(xb, y) - z(xa, y)) / ((xb - xa) * b.cell_x) : 0.0;
        const double sy = yb > ya ? (z(x, yb) - z(x, ya)) / ((yb - ya) * b.cell_y) : 0.0;
        cs[size_t(y - box.y0) * box.w + (x - box.x0)] = std::hypot(sx, sy);
      }
    auto cell_w = [&](int x, int y) {
      const double wreg = w_region(x, y);
      return wreg > 0 ? wreg * w_slope(cs[size_t(y - box.y0) * box.w + (x - box.x0)]) : 0.0;
    };
    size_t touched = 0;
    const int x0 = box.x0, y0 = box.y0, x1 = box.x0 + box.w, y1 = box.y0 + box.h;
    // The change of each face's gradient: w (S(h1) - S(h0) - (h1 - h0)) / d (gradient form, w the
    // face's weight: the reconstruction moves by S(h) - h where w is 1), or the face difference of
    // w (S(h) - h) at the cells (remap form).
    std::vector<double> dz;
    if (remap) {
      dz.assign(size_t(box.w) * box.h, 0.0);
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const double w = cell_w(x, y);
          if (w > 0) dz[size_t(y - y0) * box.w + (x - x0)] = w * (layered(x, y) - z(x, y));
        }
    }
    auto dz_at = [&](int x, int y) { return in_box(x, y) ? dz[size_t(y - y0) * box.w + (x - x0)] : 0.0; };
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x)
        for (int xface = 0; xface < 2; ++xface) {
          const int bx = x + xface, by = y + 1 - xface;  // the face's second cell
          if (bx >= W || by >= H) continue;
          double delta;
          if (remap) {
            const double a = dz_at(x, y), c = dz_at(bx, by);
            if (a == 0 && c == 0) continue;
            delta = c - a;
          } else {
            const double w = 0.5 * (cell_w(x, y) + cell_w(bx, by));
            if (!(w > 0)) continue;  // untouched: gentle ground and the outside keep their bits
            const double za = z(x, y), zb = z(bx, by);
            delta = w * ((layered(bx, by) - layered(x, y)) - (zb - za));
          }
          const size_t i = size_t(y) * W + x;
          float& v = xface ? g.gx[i] : g.gy[i];
          v = float(v + delta / (xface ? b.cell_x : b.cell_y));
          ++touched;
        }
    s.upload(g);
    s.log().back()["layer_pairs"] = stack.pairs().size();
    s.log().back()["faces"] = touched;
    // The operation's own cost, without the solve that gave it the terrain.
    s.log().back()["strata_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_start).count();
    s.changed();
  };
}

}  // namespace

void add_strata_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"strata", "layered rock in a region: hard layers steepen steep slopes into cliff bands, soft ones into benches",
                 parse_strata});
}

}  // namespace terracl::edit
