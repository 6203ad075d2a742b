// SPDX-License-Identifier: Apache-2.0
// Launchers of kernels/tensor.cl. Primitives are packed kStride (= PRIM_STRIDE) floats each:
//   [0] shape  [1] first vertex  [2] vertex count  [3] radius r  [4] mu  [5] tensor kind  [6] angle
//   [7] disc radius  [8..11] anisotropic metric M (row-major)  [12] profile  [13] profile amplitude
//   [14] [15] cos, sin of the tensor's rotation (2 angle for directional tensors)
//   [16] floor half width  [17] [18] taper lengths at the first / last vertex  [19] cliff face fraction
//   [20] scree share  [21] total arc length  [22] smooth (Hermite pieces)  [23] sharp crest rounding (x r)
// and vertices as float4 (x, y, amplitude factor, arc length from the first vertex), all in metres.
#include <terracl/error.hpp>
#include <terracl/tensor.hpp>

#include <terracl/launch.hpp>
#include "cl/row_launch.hpp"

#include <algorithm>
#include <cmath>
#include <deque>

namespace terracl {

namespace {
constexpr size_t kStride = 24;
double smoother(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * t * (t * (t * 6 - 15) + 10);
}
}  // namespace

double profile_value(Profile p, double d, double s, double r, double a, double f, double face, double scree,
                     double crest_round) {
  if (!(r > 0)) return 0;
  f = std::min(f, 0.95 * r);
  const double u = std::clamp((d - f) / (r - f), 0.0, 1.0), w = 1 - u;
  switch (p) {
    case Profile::Round: return a * alpha(u);
    // (1 - u)^3 with u from the distance rounded over crest_round r on the crest line (sqrt(d^2 +
    // rho^2) - rho): a crest a few cells wide on a wide stroke instead of a slope kink (a knife line).
    case Profile::Sharp: {
      const double rho = std::max(crest_round, 0.0) * r, ds = std::sqrt(d * d + rho * rho) - rho;
      const double v = 1 - std::clamp((ds - f) / (r - f), 0.0, 1.0);
      return a * v * v * v;
    }
    // (1 - u)^3 (1 + 3 u): steepest a third of the way up (slope 16/9 a/r), a rounded thalweg and
    // a C2 rim. The former (1 - u)^2 was steepest on the axis: a crease that read as a 1-pixel scratch.
    case Profile::V: return a * w * w * w * (1 + 3 * u);
    case Profile::U: {
      const double q = 1 - u * u * u * u;
      return a * q * q;
    }
    case Profile::Step: return a * smoother((s / r + 1) * 0.5);
    case Profile::Drop: {
      // Face over [0, c r]: smootherstep plus sigma x^4 (x - 1), which ends with the slope of the
      // apron's top (C1 at the foot; sigma = 2 k c / ((1 - k)(1 - c)) <= 3 keeps it monotone).
      // Apron over [c r, r]: 1 - (1 - v)^2, steepest at the foot, flat at the toe (a concave talus).
      const double c = std::clamp(face, 1e-3, 0.95), k = std::clamp(scree, 0.0, 0.95);
      const double x = std::clamp(s / (c * r), 0.0, 1.0), v = std::clamp((s - c * r) / ((1 - c) * r), 0.0, 1.0);
      const double sigma = std::min(2 * k * c / ((1 - k) * (1 - c)), 3.0);
      return -a * ((1 - k) * (smoother(x) + sigma * x * x * x * x * (x - 1)) + k * (1 - (1 - v) * (1 - v)));
    }
  }
  return 0;
}

std::vector<Vec2> catmull_rom(const std::vector<Vec2>& pts, double step, const std::vector<double>& z,
                              std::vector<double>* z_out) {
  const size_t n = pts.size();
  std::vector<Vec2> out;
  if (z_out) z_out->clear();
  if (n < 3 || !(step > 0)) {
    if (z_out) *z_out = z;
    return pts;
  }
  auto at = [&](long i) -> Vec2 {  // mirrored ends: P(-1) = 2 P0 - P1
    if (i < 0) return {2 * pts[0].x - pts[1].x, 2 * pts[0].y - pts[1].y};
    if (i >= long(n)) return {2 * pts[n - 1].x - pts[n - 2].x, 2 * pts[n - 1].y - pts[n - 2].y};
    return pts[size_t(i)];
  };
  auto zat = [&](long i) -> double {
    if (z.empty()) return 0;
    if (i < 0) return 2 * z[0] - z[1];
    if (i >= long(n)) return 2 * z[n - 1] - z[n - 2];
    return z[size_t(i)];
  };
  auto knot = [](const Vec2& a, const Vec2& b) { return std::max(std::sqrt(std::hypot(b.x - a.x, b.y - a.y)), 1e-9); };
  for (size_t i = 0; i + 1 < n; ++i) {
    const Vec2 p0 = at(long(i) - 1), p1 = at(long(i)), p2 = at(long(i) + 1), p3 = at(long(i) + 2);
    const double z0 = zat(long(i) - 1), z1 = zat(long(i)), z2 = zat(long(i) + 1), z3 = zat(long(i) + 2);
    const double t0 = 0, t1 = t0 + knot(p0, p1), t2 = t1 + knot(p1, p2), t3 = t2 + knot(p2, p3);
    // Pieces of at most `step`, and turning by at most ~4 degrees each: the distance to a polyline
    // creases inside every vertex (a slope jump of 2 sin(angle/2) of the profile's slope there).
    // Barry-Goldman pyramid.
    auto lerp = [](double a, double b, double ta, double tb, double t) { return tb > ta ? (a * (tb - t) + b * (t - ta)) / (tb - ta) : a; };
    auto eval_at = [&](double t, double v0, double v1, double v2, double v3) {
      const double a1 = lerp(v0, v1, t0, t1, t), a2 = lerp(v1, v2, t1, t2, t), a3 = lerp(v2, v3, t2, t3, t);
      const double b1 = lerp(a1, a2, t0, t2, t), b2 = lerp(a2, a3, t1, t3, t);
      return lerp(b1, b2, t1, t2, t);
    };
    // The segment's turning, summed over 32 sub-steps of the spline itself: the chords p0 -> p2 and
    // p1 -> p3 miss it on the end segments (the mirrored end point makes them parallel), which cut
    // a tight end segment into pieces turning by 7-10 degrees.
    double turn = 0, prev = 0;
    for (int k = 0; k <= 32; ++k) {
      const double ta = t1 + (t2 - t1) * k / 33.0, tb = t1 + (t2 - t1) * (k + 1) / 33.0;
      const double ang = std::atan2(eval_at(tb, p0.y, p1.y, p2.y, p3.y) - eval_at(ta, p0.y, p1.y, p2.y, p3.y),
                                    eval_at(tb, p0.x, p1.x, p2.x, p3.x) - eval_at(ta, p0.x, p1.x, p2.x, p3.x));
      if (k > 0) turn += std::abs(std::remainder(ang - prev, 2 * M_PI));
      prev = ang;
    }
    const int pieces = std::max({1, int(std::ceil(std::hypot(p2.x - p1.x, p2.y - p1.y) / step)),
                                 int(std::ceil(turn / (4 * M_PI / 180)))});
    for (int k = 0; k < pieces; ++k) {
      const double t = t1 + (t2 - t1) * double(k) / pieces;
      auto eval = [&](double v0, double v1, double v2, double v3) { return eval_at(t, v0, v1, v2, v3); };
      out.push_back({eval(p0.x, p1.x, p2.x, p3.x), eval(p0.y, p1.y, p2.y, p3.y)});
      if (z_out && !z.empty()) z_out->push_back(eval(z0, z1, z2, z3));
    }
  }
  out.push_back(pts[n - 1]);
  if (z_out && !z.empty()) z_out->push_back(z[n - 1]);
  return out;
}

double alpha(double t) {
  if (t < 0) t = -t;
  if (t >= 1.0) return 0.0;
  const double s = 1.0 - t * t;
  return s * s * s;
}

std::array<double, 4> directional_tensor(double theta, double mu) {
  const double c = std::cos(2 * theta), s = std::sin(2 * theta);
  return {1 + mu * c, mu * s, mu * s, 1 - mu * c};
}

Box full_box(int width, int height) { return {0, 0, width, height}; }

Box primitives_box(const std::vector<Primitive>& prims, int width, int height, double cell_x, double cell_y) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : prims) {
    // Distances in the metric are at least min(1, ratio) times the real distance.
    const double shrink = std::min(1.0, std::max(1e-3, p.aniso_ratio));
    const double inner = p.shape == PrimitiveShape::Disc || p.shape == PrimitiveShape::Polyline ? p.disc_radius : 0.0;
    const double ext = (p.radius + inner) / shrink;
    for (const auto& v : p.points) {
      x0 = std::min(x0, v.x - ext);
      x1 = std::max(x1, v.x + ext);
      y0 = std::min(y0, v.y - ext);
      y1 = std::max(y1, v.y + ext);
    }
  }
  if (x0 > x1) return {};
  auto clampi = [](double v, int lo, int hi) { return int(std::max<double>(lo, std::min<double>(hi, v))); };
  const int cx0 = clampi(std::floor(x0 / cell_x) - 1, 0, width), cx1 = clampi(std::ceil(x1 / cell_x) + 2, 0, width);
  const int cy0 = clampi(std::floor(y0 / cell_y) - 1, 0, height), cy1 = clampi(std::ceil(y1 / cell_y) + 2, 0, height);
  return {cx0, cy0, cx1 - cx0, cy1 - cy0};
}

GradientBuffers GradientBuffers::upload(Device& d, const GradientField& g) {
  GradientBuffers b;
  b.width = g.width;
  b.height = g.height;
  b.cell_x = g.georef.cell_x;
  b.cell_y = g.georef.cell_y;
  const size_t bytes = b.cells() * sizeof(float);
  b.gx = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient x");
  b.gy = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient y");
  b.tx = d.buffer(bytes, CL_MEM_READ_WRITE, "scratch x");
  b.ty = d.buffer(bytes, CL_MEM_READ_WRITE, "scratch y");
  b.mask = d.buffer(bytes, CL_MEM_READ_WRITE, "mask");
  auto& q = d.queue();
  q.enqueueWriteBuffer(b.gx, CL_FALSE, 0, bytes, g.gx.data());
  q.enqueueWriteBuffer(b.gy, CL_FALSE, 0, bytes, g.gy.data());
  const float zero = 0.f;
  d.fill(b.tx, zero, 0, b.cells());
  d.fill(b.ty, zero, 0, b.cells());
  d.fill(b.mask, zero, 0, b.cells());
  q.finish();
  return b;
}

void GradientBuffers::download(Device& d, GradientField& g) const {
  if (g.width != width || g.height != height) fail("tensor", "download: size {}x{} != {}x{}", g.width, g.height, width, height);
  const size_t bytes = cells() * sizeof(float);
  d.queue().enqueueReadBuffer(gx, CL_FALSE, 0, bytes, g.gx.data());
  d.queue().enqueueReadBuffer(gy, CL_TRUE, 0, bytes, g.gy.data());
}

void GradientBuffers::clear_scratch(Device& d, const Box& box) {
  const int r0 = std::max(0, box.y0 - 1), r1 = std::min(height, box.y0 + box.h + 1);
  if (r1 <= r0) return;
  const size_t off = size_t(r0) * width, n = size_t(r1 - r0) * width;
  d.fill(tx, 0.0f, off, n);
  d.fill(ty, 0.0f, off, n);
}

namespace {

struct Packed {
  std::vector<float> prims;
  std::vector<float> verts;
};

Packed pack(const std::vector<Primitive>& prims) {
  Packed p;
  for (const auto& pr : prims) {
    const size_t need = pr.shape == PrimitiveShape::Polyline ? 2 : pr.shape == PrimitiveShape::Polygon ? 3 : 1;
    if (pr.points.size() < need) fail("tensor", "primitive needs at least {} point(s), has {}", need, pr.points.size());
    if (!pr.amplitude.empty() && pr.amplitude.size() != pr.points.size())
      fail("tensor", "primitive has {} amplitudes for {} points", pr.amplitude.size(), pr.points.size());
    const float first = float(p.verts.size() / 4);
    double arc = 0;
    for (size_t i = 0; i < pr.points.size(); ++i) {
      if (i > 0) arc += std::hypot(pr.points[i].x - pr.points[i - 1].x, pr.points[i].y - pr.points[i - 1].y);
      p.verts.insert(p.verts.end(), {float(pr.points[i].x), float(pr.points[i].y),
                                     float(pr.amplitude.empty() ? 1.0 : pr.amplitude[i]), float(arc)});
    }
    // M = R(phi) diag(1, ratio) R(-phi): offsets along phi unchanged, across scaled by ratio.
    const double c = std::cos(pr.aniso_angle), s = std::sin(pr.aniso_angle), k = pr.aniso_ratio;
    const double m00 = c * c + k * s * s, m01 = c * s - k * c * s, m11 = s * s + k * c * c;
    // The tensor's rotation as cos/sin (of 2 angle for directional tensors, of the angle for the
    // aligned ones), float-rounded like the kernel's own cos/sin would be: saves two trig calls per face.
    const float rot = pr.tensor == TensorKind::Directional ? 2.0f * float(pr.angle) : float(pr.angle);
    p.prims.insert(p.prims.end(),
                   {float(int(pr.shape)), first, float(pr.points.size()), float(pr.radius), float(pr.strength),
                    float(int(pr.tensor)), float(pr.angle), float(pr.disc_radius), float(m00), float(m01),
                    float(m01), float(m11), float(int(pr.profile)), float(pr.profile_amplitude), std::cos(rot), std::sin(rot),
                    float(pr.floor_half_width), float(pr.taper_start), float(pr.taper_end), float(pr.face_fraction),
                    float(pr.scree), float(arc), pr.smooth && pr.shape == PrimitiveShape::Polyline ? 1.f : 0.f, float(pr.crest_round)});
  }
  if (p.verts.empty()) p.verts.assign(4, 0.f);
  if (p.prims.empty()) p.prims.assign(kStride, 0.f);
  return p;
}

}  // namespace

// The tensor kernels' parameters live in one persistent buffer per field:
// before, every launch created two buffers (CL_MEM_COPY_HOST_PTR: an allocation and a transfer
// each; ~0.3 ms per operation on an H100). Now each launch does one non-blocking write of its
// packed block into [prims | vertices] sub-buffers of that buffer, which grows (doubling) only
// when a block does not fit. The queue is in order, so a write waits for the previous launch
// that read the buffer; the host copy of each block stays alive until its write has completed.
struct SkeletonParams {
  cl::Buffer all, prims, verts;
  size_t prim_floats = 0, vert_floats = 0;  // capacities of the two regions
  std::deque<std::pair<cl::Event, std::vector<float>>> pending;  // writes in flight and their host blocks

  ~SkeletonParams() {
    // The device may still read the host blocks; in an in-order queue the last write completes last.
    if (!pending.empty()) pending.back().first.wait();
  }
};

namespace {

struct DeviceSkeleton {
  cl::Buffer prims, verts;
  int count = 0;
};

DeviceSkeleton upload(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims) {
  Packed p = pack(prims);
  if (!g.skeleton) g.skeleton = std::make_shared<SkeletonParams>();
  SkeletonParams& sp = *g.skeleton;
  while (!sp.pending.empty() && sp.pending.front().first.getInfo<CL_EVENT_COMMAND_EXECUTION_STATUS>() == CL_COMPLETE)
    sp.pending.pop_front();
  if (p.prims.size() > sp.prim_floats || p.verts.size() > sp.vert_floats || !sp.all()) {
    // The vertex region starts at a multiple of the device's sub-buffer alignment.
    const size_t align = std::max<size_t>(d.device().getInfo<CL_DEVICE_MEM_BASE_ADDR_ALIGN>() / 8, sizeof(float)) / sizeof(float);
    size_t pf = std::max<size_t>(sp.prim_floats, 64 * kStride), vf = std::max<size_t>(sp.vert_floats, 4096);
    while (pf < p.prims.size()) pf *= 2;
    while (vf < p.verts.size()) vf *= 2;
    pf = (pf + align - 1) / align * align;
    cl::Buffer all = d.buffer((pf + vf) * sizeof(float), CL_MEM_READ_ONLY, "tensor primitives");
    cl_buffer_region rp{0, pf * sizeof(float)}, rv{pf * sizeof(float), vf * sizeof(float)};
    sp.prims = all.createSubBuffer(CL_MEM_READ_ONLY, CL_BUFFER_CREATE_TYPE_REGION, &rp);
    sp.verts = all.createSubBuffer(CL_MEM_READ_ONLY, CL_BUFFER_CREATE_TYPE_REGION, &rv);
    sp.all = all;
    sp.prim_floats = pf, sp.vert_floats = vf;
  }
  // One block, one write: the primitives, zero padding to the vertex region, the vertices.
  std::vector<float> block(sp.prim_floats + p.verts.size(), 0.f);
  std::copy(p.prims.begin(), p.prims.end(), block.begin());
  std::copy(p.verts.begin(), p.verts.end(), block.begin() + std::ptrdiff_t(sp.prim_floats));
  cl::Event ev;
  d.queue().enqueueWriteBuffer(sp.all, CL_FALSE, 0, block.size() * sizeof(float), block.data(), nullptr, &ev);
  sp.pending.emplace_back(std::move(ev), std::move(block));  // the vector's heap block does not move
  return {sp.prims, sp.verts, int(prims.size())};
}

// Work-groups of 16 rows for these compute-heavy row kernels (4-row groups, the CPU default of
// launch_rows, measured up to ~10 % slower on the edit benchmark).
constexpr size_t kTensorRows = 16;
// Cells per work-item of kernels/tensor.cl's vector loops (VW in kernels/vec8.clh).
constexpr int kVW = 8;

// The tensor kernels are cell kernels (kernels/launch.clh) over `w` columns (VW-cell chunks for the
// vector ones): the wide shape launches them in the device's groups, the rows shape keeps its
// 16-row groups.
void tensor_grid(Device& d, cl::Kernel& k, size_t w, size_t h) {
  if (h == 0) return;
  if (d.info().launch == "wide") return launch_grid(d, k, w, h);
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(1, round_up(h, kTensorRows)), cl::NDRange(1, kTensorRows));
}

void tensor_launch(Device& d, const cl::Buffer& sx, const cl::Buffer& sy, GradientBuffers& g,
                   const std::vector<Primitive>& prims, const Box& box, int add) {
  const DeviceSkeleton s = upload(d, g, prims);
  cl::Kernel k = d.kernel("tensor", "apply_tensor_field");
  set_args(k, sx, sy, g.gx, g.gy, g.width, g.height, float(g.cell_x), float(g.cell_y), box.x0, box.y0, box.w, box.h,
           s.prims, s.count, s.verts, add);
  tensor_grid(d, k, size_t(box.w + kVW - 1) / kVW, size_t(box.h));
}

// Modes of kernels/tensor.cl's primitive_field (FIELD_*).
constexpr int kFieldWeight = 0, kFieldWeightInverted = 1, kFieldProfile = 2;

// mask = the primitives' weight or profile potential on `box`.
void field_launch(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims, const Box& box, int mode) {
  if (box.empty()) return;
  const DeviceSkeleton s = upload(d, g, prims);
  cl::Kernel k = d.kernel("tensor", "primitive_field");
  set_args(k, g.mask, g.width, g.height, float(g.cell_x), float(g.cell_y), box.x0, box.y0, box.w, box.h, s.prims,
           s.count, s.verts, mode);
  tensor_grid(d, k, size_t(box.w + kVW - 1) / kVW, size_t(box.h));
}

}  // namespace

void apply_tensor_field(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims) {
  const Box box = primitives_box(prims, g.width, g.height, g.cell_x, g.cell_y);
  if (box.empty()) return;
  // The kernel reads the unmodified field around each face, so it reads a copy of the box
  // (plus one cell) and writes the field.
  const int x0 = std::max(0, box.x0 - 1), y0 = std::max(0, box.y0 - 1);
  const int x1 = std::min(g.width, box.x0 + box.w + 1), y1 = std::min(g.height, box.y0 + box.h + 1);
  const std::array<size_t, 3> origin{size_t(x0) * sizeof(float), size_t(y0), 0};
  const std::array<size_t, 3> region{size_t(x1 - x0) * sizeof(float), size_t(y1 - y0), 1};
  const size_t pitch = size_t(g.width) * sizeof(float);
  auto& q = d.queue();
  q.enqueueCopyBufferRect(g.gx, g.tx, origin, origin, region, pitch, 0, pitch, 0);
  q.enqueueCopyBufferRect(g.gy, g.ty, origin, origin, region, pitch, 0, pitch, 0);
  tensor_launch(d, g.tx, g.ty, g, prims, box, 0);
}

void add_tensor_field_of_scratch(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims, const Box& box) {
  if (box.empty()) return;
  tensor_launch(d, g.tx, g.ty, g, prims, box, 1);
}

void primitive_weight(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims, const Box& box, bool invert) {
  field_launch(d, g, prims, box, invert ? kFieldWeightInverted : kFieldWeight);
}

void add_profile_gradient(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims) {
  const Box box = primitives_box(prims, g.width, g.height, g.cell_x, g.cell_y);
  field_launch(d, g, prims, box, kFieldProfile);  // the potential, into the mask scratch
  if (box.empty()) return;
  cl::Kernel k = d.kernel("tensor", "add_potential_gradient");
  set_args(k, g.gx, g.gy, g.mask, g.width, g.height, float(g.cell_x), float(g.cell_y), box.x0, box.y0, box.w, box.h);
  tensor_grid(d, k, size_t(box.w), size_t(box.h));
}

}  // namespace terracl
