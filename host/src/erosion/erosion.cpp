// SPDX-License-Identifier: Apache-2.0
// Launcher of kernels/erosion.cl: state upload with a zero halo, automatic sub-stepping, the kernel
// sequence per sub-step (no clFinish inside a run), totals in double on the host.
#include <terracl/erosion.hpp>
#include <terracl/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

namespace terracl {

namespace {

constexpr int kPad = 8;  // pad columns on the left; must match PAD in kernels/erosion.cl
constexpr const char* kStage = "erode";
constexpr double kWaterDensity = 1000.0;  // kg/m^3, rho_w of the critical shear stress

void check_param(double v, const char* name, double lo, double hi = INFINITY) {
  if (!std::isfinite(v) || v < lo || v > hi)
    fail(kStage, "parameter {} = {} is out of range (expected a finite value in [{}, {}])", name, v, lo, hi);
}

void validate(const ErosionParams& p) {
  check_param(p.dt, "dt", 0, 1e9);
  check_param(p.rain, "rain", 0, 1e3);
  check_param(p.evaporation, "evaporation", 0, 1e6);
  check_param(p.gravity, "gravity", 1e-6, 1e6);
  check_param(p.pipe_area, "pipe_area", 0, 1e18);
  check_param(p.damping, "damping", 0, 1e9);
  check_param(p.capacity, "capacity", 0, 1e9);
  check_param(p.dissolve, "dissolve", 0, 1e9);
  check_param(p.deposit, "deposit", 0, 1e9);
  check_param(p.min_sin_slope, "min_sin_slope", 0, 1);
  check_param(p.critical_shear, "critical_shear", 0, 1e9);
  check_param(p.depth_ramp, "depth_ramp", 0, 1e9);
  check_param(p.max_change, "max_change", 0, 1e9);
  check_param(p.dry_depth, "dry_depth", 1e-9, 1e3);
  check_param(p.thermal_rate, "thermal_rate", 0, 1e9);
  check_param(p.diffusion, "diffusion", 0, 1e9);
  check_param(p.channel_diffusion, "channel_diffusion", 0, 1e9);
  check_param(p.talus_deg, "talus", 0, 89.9);
  check_param(p.substep_fraction, "substep_fraction", 1e-3, 100);
  check_param(p.rock_erodibility, "rock_erodibility", 0, 1);
  check_param(p.deposit_talus_deg, "deposit_talus", 0, 89.9);
  check_param(p.recession, "recession", 0, 1e7);
  check_param(p.max_concentration, "max_concentration", 0, 1e9);
  check_param(p.settling_velocity, "settling_velocity", 0, 1e6);
  check_param(p.recession_concentration, "recession_concentration", 0, 1e9);
  check_param(p.recession_evaporation, "recession_evaporation", 0, 1e6);
}

}  // namespace

ErosionParams ErosionParams::defaults() {
  // Tuned on the bundled SRTM crops (66-92 m cells): detachment-limited (dissolve << 1/dt, high
  // capacity) so that erosion grows with discharge and carves gullies, and a slow deposit so that
  // fine sediment stays suspended in lakes instead of filling every valley flat.
  ErosionParams p;
  p.rain = 0.003;
  // Undamped pipes (the published model has no damping) let the water and its load run on through
  // the trunk valleys and out of a crop within the run, little evaporation keeps the load afloat
  // until then, and a slow pick-up keeps the carving. With damping 0.5, evaporation 0.02 and
  // dissolve 0.015 the load of 400 s of gullying stops in the trunk valleys and settles there as
  // raised flat ribbons (docs/erosion.md, "Parameters").
  p.evaporation = 0.002;
  p.damping = 0.0;
  p.capacity = 20.0;
  p.dissolve = 0.008;
  p.deposit = 0.001;
  p.min_sin_slope = 0.05;
  p.depth_ramp = 5.0;
  // Channel widening: banks slump into water that cuts (docs/erosion.md, "Does it read as nature").
  p.channel_diffusion = 2.0;
  // Excess shear: 200 Pa (tau = rho_w g d S: 2 cm of water on a 1:1 slope, 0.4 m on a 5 % one) keeps
  // the sheet flow of the hillslopes from cutting them; the concentrated flow of hollows and valleys
  // cuts. Bank failure only where water cuts: the input's own cliffs and scarps stand.
  p.critical_shear = 200.0;
  p.thermal_banks_only = true;
  p.creep_into_cuts = true;
  p.max_change = 0.5;  // m/s: 0.5 m per ~1 s sub-step of the SRTM3 tiles it was tuned on
  p.thermal_rate = 0.05;
  p.talus_deg = 35.0;
  // Hillslope creep of 0.5 m^2/s smooths the one-cell crinkles of a 10 m grid in ~200 s (w^2/D) and
  // leaves the texture of a 30 m DEM (1800 s) where no water concentrates; an open border lets the valleys drain out of a DEM crop instead of filling as lakes
  // against a wall that is not there; a low rain keeps the incision a few metres.
  p.diffusion = 0.5;
  p.boundary = ErosionBoundary::Open;
  return p;
}

double erosion_pipe_area(const ErosionParams& p, double lx, double ly) {
  return p.pipe_area > 0 ? p.pipe_area : std::sqrt(lx * ly) * ErosionParams::pipe_reference_length;
}

double erosion_stability_limit(const ErosionParams& p, double lx, double ly) {
  const double a = lx * ly;
  const double area = erosion_pipe_area(p, lx, ly);
  return std::sqrt(a / (p.gravity * (area / lx + area / ly)));
}

struct Erosion::Impl {
  Device& dev;
  ErosionParams p;
  Heightfield meta;  // georef and metadata of the input (no elevations)
  int W = 0, H = 0, P = 0;
  size_t n_padded = 0;
  double lx = 1, ly = 1;
  bool has_weight = false;
  cl::Buffer b[2], d[2], s[2], f[4], w, drain, r[2], q, b0;
  size_t chunks = 1;        // work-items per row (global size of dimension 1)
  size_t local_rows = 4, local_chunks = 1;
  int cur = 0;  // index of the current d/s (and b when thermal is off)
  int bcur = 0;
  cl::Kernel k_flux, k_transport, k_thermal;
  std::vector<double> drained{0.0, 0.0};
  std::vector<float> initial;  // the bed before the erosion: route_sediment refills no higher
  double rained = 0;

  explicit Impl(Device& device) : dev(device) {}

  size_t at(int x, int y) const { return size_t(y + 1) * P + kPad + x; }

  std::vector<float> pad(const std::vector<float>& v) const {
    std::vector<float> out(n_padded, 0.0f);
    for (int y = 0; y < H; ++y) std::copy_n(v.begin() + size_t(y) * W, W, out.begin() + at(0, y));
    return out;
  }
  std::vector<float> unpad(const std::vector<float>& v) const {
    std::vector<float> out(size_t(W) * H);
    for (int y = 0; y < H; ++y) std::copy_n(v.begin() + at(0, y), W, out.begin() + size_t(y) * W);
    return out;
  }
  void upload(cl::Buffer& buf, const std::vector<float>& v) {
    auto padded = pad(v);
    dev.queue().enqueueWriteBuffer(buf, CL_TRUE, 0, padded.size() * 4, padded.data());
  }
  std::vector<float> download(const cl::Buffer& buf) {
    std::vector<float> padded(n_padded);
    dev.queue().enqueueReadBuffer(buf, CL_TRUE, 0, padded.size() * 4, padded.data());
    return unpad(padded);
  }
  /// Adds the per-row border drain accumulated on the device to the double totals and resets it.
  void collect_drain() {
    if (p.boundary != ErosionBoundary::Open || p.thermal_only) return;
    std::vector<float> rows(size_t(2) * H * chunks);
    dev.queue().enqueueReadBuffer(drain, CL_TRUE, 0, rows.size() * 4, rows.data());
    for (size_t k = 0; k < rows.size() / 2; ++k) drained[0] += rows[2 * k], drained[1] += rows[2 * k + 1];
    dev.fill(drain, 0.0f, 0, rows.size());
  }
};

Erosion::Erosion(Device& dev, const Heightfield& terrain, const ErosionParams& params,
                 const std::vector<float>* weight, const std::vector<float>* water,
                 const std::vector<float>* deposit)
    : m(std::make_unique<Impl>(dev)) {
  validate(params);
  if (terrain.width < 1 || terrain.height < 1) fail(kStage, "empty heightfield");
  require_finite(terrain, kStage, "input heightfield");
  for (float v : terrain.z)
    if (std::fabs(v) > 1e7f) fail(kStage, "input elevation {} m is beyond +-1e7 m; refusing to erode it", v);
  const double lx = terrain.georef.cell_x, ly = terrain.georef.cell_y;
  if (!(std::isfinite(lx) && std::isfinite(ly) && lx > 0 && ly > 0))
    fail(kStage, "cell size {} x {} m is not positive and finite", lx, ly);
  const size_t n = terrain.size();
  if (weight) {
    if (weight->size() != n) fail(kStage, "weight has {} values, the grid {}", weight->size(), n);
    for (float v : *weight)
      if (!(v >= 0.0f && v <= 1.0f)) fail(kStage, "weight value {} is outside [0, 1]", v);
  }
  if (water) {
    if (water->size() != n) fail(kStage, "initial water has {} values, the grid {}", water->size(), n);
    for (float v : *water)
      if (!(std::isfinite(v) && v >= 0.0f)) fail(kStage, "initial water depth {} is not finite and >= 0", v);
  }

  if (deposit) {
    if (!params.deposit_layer) fail(kStage, "an initial deposit needs the deposit layer enabled");
    if (deposit->size() != n) fail(kStage, "initial deposit has {} values, the grid {}", deposit->size(), n);
    for (float v : *deposit)
      if (!(std::isfinite(v) && v >= 0.0f)) fail(kStage, "initial deposit thickness {} is not finite and >= 0", v);
  }
  Impl& s = *m;
  s.p = params;
  s.W = terrain.width;
  s.H = terrain.height;
  s.P = int(round_up(size_t(s.W), 8)) + 2 * kPad;
  s.n_padded = size_t(s.H + 2) * s.P;
  s.lx = lx;
  s.ly = ly;
  s.has_weight = weight != nullptr;
  s.initial = terrain.z;
  s.meta.width = terrain.width;
  s.meta.height = terrain.height;
  s.meta.georef = terrain.georef;
  s.meta.metadata = terrain.metadata;

  m_dt_limit = erosion_stability_limit(params, lx, ly);
  const double dt_max = params.substep_fraction * m_dt_limit;
  const double dt = params.dt > 0 ? params.dt : dt_max;
  m_substeps = std::max(1, int(std::ceil(dt / dt_max * (1.0 - 1e-12))));
  if (m_substeps > 1000000) fail(kStage, "dt = {} s needs {} sub-steps (limit {} s); use a smaller dt", dt, m_substeps, dt_max);
  m_dt_sub = dt / m_substeps;

  // Work split (see XCHUNK in kernels/erosion.cl).
  int chunk = params.cells_per_item;
  if (chunk < 0) fail(kStage, "cells_per_item must be >= 0, got {}", chunk);
  if (chunk == 0) chunk = dev.info().launch == "wide" ? 32 : 0;
  chunk = int(round_up(size_t(chunk), 8));
  if (chunk > 0 && chunk < s.W) {
    s.local_rows = 1;
    s.local_chunks = dev.info().launch == "wide" ? 32 : 16;  // a whole warp on wide devices
    s.chunks = round_up((size_t(s.W) + chunk - 1) / chunk, s.local_chunks);
  }

  const size_t bytes = s.n_padded * sizeof(float);
  try {
    for (int k = 0; k < 2; ++k) {
      s.b[k] = dev.buffer(bytes, CL_MEM_READ_WRITE, "erosion bed");
      s.d[k] = dev.buffer(bytes, CL_MEM_READ_WRITE, "erosion water");
      s.s[k] = dev.buffer(bytes, CL_MEM_READ_WRITE, "erosion sediment");
    }
    for (auto& f : s.f) f = dev.buffer(bytes, CL_MEM_READ_WRITE, "erosion flux");
    s.w = dev.buffer(s.has_weight ? bytes : 4, CL_MEM_READ_ONLY, "erosion weight");
    for (auto& r : s.r) r = dev.buffer(params.deposit_layer ? bytes : 4, CL_MEM_READ_WRITE, "erosion deposit layer");
    if (params.deposit_layer) {
      dev.queue().enqueueWriteBuffer(s.r[1], CL_TRUE, 0, bytes, std::vector<float>(s.n_padded, 0.0f).data());
      s.upload(s.r[0], deposit ? *deposit : std::vector<float>(n, 0.0f));
    }
    const bool channel = (params.channel_diffusion > 0 || params.thermal_banks_only) && !params.thermal_only;
    s.q = dev.buffer(channel ? bytes : 4, CL_MEM_READ_WRITE, "erosion unit discharge");
    // The bed before the erosion: the channel and bank-failure shares fill no cell above it.
    s.b0 = dev.buffer(channel ? bytes : 4, CL_MEM_READ_ONLY, "erosion initial bed");
    if (channel) s.upload(s.b0, terrain.z);
    if (channel) dev.fill(s.q, 0.0f, 0, s.n_padded);
    s.drain = dev.buffer(size_t(2) * s.H * s.chunks * sizeof(float), CL_MEM_READ_WRITE, "erosion drain");

    s.upload(s.b[0], terrain.z);
    const std::vector<float> zeros(n, 0.0f);
    const std::vector<float> padded_zero(s.n_padded, 0.0f);
    for (int k = 0; k < 2; ++k) {
      // Pads must be zero in every buffer, including the ones written only later.
      if (k == 1) dev.queue().enqueueWriteBuffer(s.b[1], CL_TRUE, 0, bytes, padded_zero.data());
      s.upload(s.d[k], water && k == 0 ? *water : zeros);
      s.upload(s.s[k], zeros);
    }
    for (auto& f : s.f) dev.queue().enqueueWriteBuffer(f, CL_TRUE, 0, bytes, padded_zero.data());
    if (s.has_weight) s.upload(s.w, *weight);
    std::vector<float> drain0(size_t(2) * s.H * s.chunks, 0.0f);
    dev.queue().enqueueWriteBuffer(s.drain, CL_TRUE, 0, drain0.size() * 4, drain0.data());

    const std::string opts = erosion_program_options(dev, s.W, params, s.has_weight);
    s.k_flux = dev.kernel("erosion", "erosion_flux", opts);
    s.k_transport = dev.kernel("erosion", "erosion_transport", opts);
    s.k_thermal = dev.kernel("erosion", "erosion_thermal", opts);

    // Arguments that never change.
    const ErosionParams& p = params;
    const double h = m_dt_sub, a = lx * ly;
    const double area = erosion_pipe_area(p, lx, ly);
    const float rain_dt = float(p.rain * h);
    {
      cl::Kernel& k = s.k_flux;
      for (int i = 0; i < 4; ++i) k.setArg(2 + i, s.f[i]);
      k.setArg(6, s.W);
      k.setArg(7, s.H);
      k.setArg(8, s.P);
      k.setArg(9, rain_dt);
      k.setArg(10, float(h * area * p.gravity / lx));
      k.setArg(11, float(h * area * p.gravity / ly));
      k.setArg(12, float(1.0 / (1.0 + h * p.damping)));
      k.setArg(13, float(a / h));
    }
    {
      cl::Kernel& k = s.k_transport;
      for (int i = 0; i < 4; ++i) k.setArg(3 + i, s.f[i]);
      k.setArg(7, s.w);
      k.setArg(11, s.drain);
      k.setArg(12, s.W);
      k.setArg(13, s.H);
      k.setArg(14, s.P);
      k.setArg(15, rain_dt);
      k.setArg(16, float(h / a));
      k.setArg(17, float(0.5 / lx));
      k.setArg(18, float(0.5 / ly));
      k.setArg(19, float(1.0 / lx));
      k.setArg(20, float(1.0 / ly));
      k.setArg(21, float(0.5 * std::min(lx, ly) / h));
      k.setArg(22, float(p.capacity));
      k.setArg(23, float(p.min_sin_slope));
      k.setArg(24, float(p.depth_ramp > 0 ? 1.0 / p.depth_ramp : 1e30));
      k.setArg(25, float(std::min(1.0, p.dissolve * h)));
      k.setArg(26, float(std::min(1.0, p.deposit * h)));
      k.setArg(27, float(p.max_change * h));  // a rate: the same cap per second at any sub-step length
      k.setArg(28, float(p.dry_depth));
      k.setArg(29, float(std::max(0.0, 1.0 - p.evaporation * h)));
      k.setArg(30, float(a));
      k.setArg(33, float(p.deposit_layer ? p.rock_erodibility : 1.0));
      k.setArg(34, s.q);
      k.setArg(35, 0.0f);  // no settling velocity while it rains; 36: the pick-up bound (1e30 = none)
      k.setArg(36, float(p.max_concentration > 0 ? p.max_concentration : 1e30));
      k.setArg(37, float(p.critical_shear / (kWaterDensity * p.gravity)));  // tau_c/(rho_w g), m
      k.setArg(38, s.b0);
    }
    {
      cl::Kernel& k = s.k_thermal;
      k.setArg(1, s.w);
      k.setArg(3, s.W);
      k.setArg(4, s.H);
      k.setArg(5, s.P);
      const double t = std::tan(p.talus_deg * M_PI / 180.0);
      k.setArg(6, float(std::min(p.thermal_rate * h, 1.0 / 12.0)));
      k.setArg(7, float(t * lx));
      k.setArg(8, float(t * ly));
      k.setArg(9, float(t * std::hypot(lx, ly)));
      const double td = std::tan(p.deposit_talus_deg * M_PI / 180.0);
      k.setArg(12, float(td * lx));
      k.setArg(13, float(td * ly));
      k.setArg(14, float(td * std::hypot(lx, ly)));
      // Diffusion: pair weights whose sum is exactly D*dt times the second-order Laplacian for any
      // cell aspect (diagonals 1/4 / (lx^2+ly^2); axis weights make up the rest of d2/dx2, d2/dy2).
      // The sum over the 8 pairs is capped at 1/4 so that with the thermal share (<= 8/12) a cell
      // never gives away more than it has above its neighbours (binds only below ~0.2*D m cells).
      const double dd = lx * lx + ly * ly;
      const double gx = h * (1.0 - 0.5 * lx * lx / dd) / (lx * lx), gy = h * (1.0 - 0.5 * ly * ly / dd) / (ly * ly);
      const double gdiag = h * 0.25 / dd, gsum = 2 * gx + 2 * gy + 4 * gdiag;
      double kx = p.diffusion * gx, ky = p.diffusion * gy, kdiag = p.diffusion * gdiag;
      const double ksum = 2 * kx + 2 * ky + 4 * kdiag;
      if (ksum > 0.25) kx *= 0.25 / ksum, ky *= 0.25 / ksum, kdiag *= 0.25 / ksum;
      k.setArg(15, float(kx));
      k.setArg(16, float(ky));
      k.setArg(17, float(kdiag));
      // Channel diffusion K_q * (q_c + q_n) / 2 on the same pair weights, each pair capped at its
      // share of the same 1/4 (the kernel takes the pair's discharge sum, hence the 1/2 here).
      k.setArg(18, s.q);
      const double kq = 0.5 * p.channel_diffusion;
      k.setArg(19, float(kq * gx));
      k.setArg(20, float(kq * gy));
      k.setArg(21, float(kq * gdiag));
      k.setArg(22, float(0.25 * gx / gsum));
      k.setArg(23, float(0.25 * gy / gsum));
      k.setArg(24, float(0.25 * gdiag / gsum));
      k.setArg(25, s.b0);
    }
  } catch (const cl::Error& e) {
    fail(kStage, "setting up the device state: {}", describe(e));
  }
}

Erosion::~Erosion() = default;

void Erosion::enqueue_steps(int n) {
  Impl& s = *m;
  const bool thermal = s.p.thermal_rate > 0 || s.p.diffusion > 0 || s.p.channel_diffusion > 0;
  // A fixed local size: PoCL compiles one work-group function per local size, and NullRange would
  // let it pick a different one for every grid height. CPUs: 4 rows per group; GPUs: 16 chunks.
  const cl::NDRange global(round_up(size_t(s.H), s.local_rows), s.chunks), local(s.local_rows, s.local_chunks);
  auto& q = s.dev.queue();
  try {
    for (int step = 0; step < n; ++step) {
      for (int sub = 0; sub < m_substeps; ++sub) {
        if (!s.p.thermal_only) {
          const int c = s.cur, nx = 1 - s.cur, bc = s.bcur, bn = 1 - s.bcur;
          s.k_flux.setArg(0, s.b[bc]);
          s.k_flux.setArg(1, s.d[c]);
          q.enqueueNDRangeKernel(s.k_flux, cl::NullRange, global, local);
          s.k_transport.setArg(0, s.b[bc]);
          s.k_transport.setArg(1, s.d[c]);
          s.k_transport.setArg(2, s.s[c]);
          s.k_transport.setArg(8, s.b[bn]);
          s.k_transport.setArg(9, s.d[nx]);
          s.k_transport.setArg(10, s.s[nx]);
          s.k_transport.setArg(31, s.r[bc]);
          s.k_transport.setArg(32, s.r[bn]);
          q.enqueueNDRangeKernel(s.k_transport, cl::NullRange, global, local);
          s.cur = nx;
          s.bcur = bn;
          s.rained += s.p.rain * m_dt_sub * s.lx * s.ly * double(s.W) * s.H;
        }
        if (thermal) {
          s.k_thermal.setArg(0, s.b[s.bcur]);
          s.k_thermal.setArg(2, s.b[1 - s.bcur]);
          s.k_thermal.setArg(10, s.r[s.bcur]);
          s.k_thermal.setArg(11, s.r[1 - s.bcur]);
          q.enqueueNDRangeKernel(s.k_thermal, cl::NullRange, global, local);
          s.bcur = 1 - s.bcur;
        }
      }
      ++m_steps;
    }
  } catch (const cl::Error& e) {
    fail(kStage, "running the erosion kernels: {}", describe(e));
  }
}

int Erosion::recession_steps() const {
  if (m->p.thermal_only || !(m->p.recession > 0)) return 0;
  return int(std::min(1e6, std::ceil(m->p.recession / step_dt() * (1.0 - 1e-12))));
}

void Erosion::begin_recession() {
  Impl& s = *m;
  if (s.p.thermal_only) return;
  const double h = m_dt_sub;
  try {
    s.k_flux.setArg(9, 0.0f);
    s.k_transport.setArg(15, 0.0f);
    s.k_transport.setArg(35, float(s.p.settling_velocity * h));
    if (s.p.recession_concentration > 0) s.k_transport.setArg(36, float(s.p.recession_concentration));
    s.k_transport.setArg(29, float(std::max(0.0, 1.0 - s.p.recession_evaporation * h)));
  } catch (const cl::Error& e) {
    fail(kStage, "starting the recession: {}", describe(e));
  }
  s.p.rain = 0;  // no more rain in the totals either
}

void Erosion::finish() {
  try {
    m->dev.queue().finish();
  } catch (const cl::Error& e) {
    fail(kStage, "running the erosion kernels: {}", describe(e));
  }
}

void Erosion::run(int n, const Progress& progress, const std::string& stage) {
  if (n < 0) fail(stage, "negative step count {}", n);
  report_progress(progress, stage, 0.0, "eroding");
  // Report often enough for a smooth bar (every ~0.1 s and at least every 1 % of the run), but never
  // wait for the device after every step: each wait costs tens of microseconds on PoCL.
  const int max_chunk = std::max(1, n / 100);
  int chunk = 1;
  int done = 0;
  while (done < n) {
    const int k = std::min(chunk, n - done);
    const auto t0 = std::chrono::steady_clock::now();
    enqueue_steps(k);
    finish();
    m->collect_drain();
    done += k;
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (secs < 0.1) chunk = std::min(chunk * 2, max_chunk);
    report_progress(progress, stage, double(done) / std::max(1, n), fmt::format("step {}/{}", done, n));
  }
}

ErosionState Erosion::state() {
  finish();
  Impl& s = *m;
  ErosionState st;
  st.width = s.W;
  st.height = s.H;
  try {
    st.bed = s.download(s.b[s.bcur]);
    st.water = s.download(s.d[s.cur]);
    st.sediment = s.download(s.s[s.cur]);
    st.flux_l = s.download(s.f[0]);
    st.flux_r = s.download(s.f[1]);
    st.flux_t = s.download(s.f[2]);
    st.flux_b = s.download(s.f[3]);
    if (s.p.deposit_layer) st.deposit = s.download(s.r[s.bcur]);
  } catch (const cl::Error& e) {
    fail(kStage, "reading the erosion state: {}", describe(e));
  }
  return st;
}

ErosionTotals Erosion::totals() {
  const ErosionState st = state();
  m->collect_drain();
  const double a = m->lx * m->ly;
  ErosionTotals t;
  for (size_t i = 0; i < st.bed.size(); ++i) {
    t.water += double(st.water[i]);
    t.sediment += double(st.sediment[i]);
    t.solid += double(st.bed[i]) + double(st.sediment[i]);
  }
  t.water *= a;
  t.sediment *= a;
  t.solid *= a;
  t.drained_water = m->drained[0];
  t.drained_sediment = m->drained[1];
  t.rained = m->rained;
  return t;
}

Heightfield Erosion::bed() {
  Heightfield h = m->meta;
  finish();
  try {
    h.z = m->download(m->b[m->bcur]);
  } catch (const cl::Error& e) {
    fail(kStage, "reading the bed: {}", describe(e));
  }
  return h;
}

double settle_sediment(Heightfield& bed, std::vector<float>& sediment, std::vector<float>& deposit,
                       const std::vector<float>* weight) {
  // The suspended sediment settles where it is, so the output holds all the solid material
  // (bed + sediment is what the simulation conserves). Under a brush only the cell's weight of
  // it settles: a weight-0 cell keeps its elevation, and what stays suspended is reported.
  double settled = 0;
  const double a = bed.georef.cell_x * bed.georef.cell_y;
  for (size_t i = 0; i < bed.size(); ++i) {
    const float s = sediment[i];
    if (!(s > 0)) continue;
    const float w = weight ? std::clamp((*weight)[i], 0.0f, 1.0f) : 1.0f;
    const float before = bed.z[i];
    bed.z[i] = before + w * s;
    const float landed = bed.z[i] - before;  // what the float bed really took (see docs: rounding)
    // A full-weight cell keeps no sediment; the sub-ulp remainder of the addition is round-off.
    sediment[i] = w >= 1.0f ? 0.0f : std::max(0.0f, s - landed);
    if (!deposit.empty()) deposit[i] += landed;  // settled sediment is loose: deposit layer
    settled += double(landed) * a;
  }
  return settled;
}

double route_sediment(Heightfield& bed, const std::vector<float>& initial, std::vector<float>& sediment,
                      std::vector<float>& deposit, const std::vector<float>* weight, bool open_border,
                      double* drained, int reach) {
  const int W = bed.width, H = bed.height;
  const size_t n = bed.size();
  if (initial.size() != n || sediment.size() != n) fail(kStage, "route_sediment: sizes differ");
  const double a = bed.georef.cell_x * bed.georef.cell_y;
  // Priority-flood (Barnes et al. 2014) from the border cells on the bed as it is: every cell gets a
  // parent (the cell it drains to, through depressions to their spill point) and a water level (its
  // bed, or the spill level of the depression it lies in). Ties by index: the same order every run.
  using Item = std::pair<float, size_t>;
  auto later = [](const Item& p, const Item& q) { return p.first > q.first || (p.first == q.first && p.second > q.second); };
  std::priority_queue<Item, std::vector<Item>, decltype(later)> open(later);
  std::vector<long> parent(n, -2);  // -2: not reached yet, -1: a border seed
  std::vector<float> level(n);
  std::vector<size_t> visit;
  visit.reserve(n);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (x == 0 || y == 0 || x == W - 1 || y == H - 1) {
        const size_t i = size_t(y) * W + x;
        parent[i] = -1, level[i] = bed.z[i];
        open.push({level[i], i});
      }
  while (!open.empty()) {
    const size_t i = open.top().second;
    open.pop();
    visit.push_back(i);
    const int x = int(i % W), y = int(i / W);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xn = x + dx, yn = y + dy;
        if ((dx == 0 && dy == 0) || xn < 0 || yn < 0 || xn >= W || yn >= H) continue;
        const size_t j = size_t(yn) * W + xn;
        if (parent[j] != -2) continue;
        parent[j] = long(i);
        level[j] = std::max(bed.z[j], level[i]);
        open.push({level[j], j});
      }
  }
  // Depressions: connected cells below their flood level (the spill level), labelled along the
  // flood's parent links; each collects the load that reaches it into a pool and fills as a lake, flat
  // to one level (so the result moves continuously with the bed, unlike filling cell by cell), and
  // passes what overflows on to its outlet (the spill cell it was entered from).
  std::vector<int> dep(n, -1);
  std::vector<size_t> dep_first, dep_count;  // per depression: the first cell the flood entered, cells
  for (size_t i : visit)
    if (level[i] > bed.z[i] && parent[i] >= 0) {
      const size_t p = size_t(parent[i]);
      if (dep[p] >= 0 && level[p] == level[i]) {
        dep[i] = dep[p];
      } else {
        dep[i] = int(dep_first.size());
        dep_first.push_back(i);
        dep_count.push_back(0);
      }
      ++dep_count[size_t(dep[i])];
    }
  std::vector<std::vector<size_t>> dep_cells(dep_first.size());
  for (size_t k = 0; k < dep_cells.size(); ++k) dep_cells[k].reserve(dep_count[k]);
  for (size_t i : visit)
    if (dep[i] >= 0) dep_cells[size_t(dep[i])].push_back(i);
  std::vector<double> pool(dep_first.size(), 0.0);

  std::vector<double> carry(n, 0.0), hops(n, 0.0);  // hops: the carry's load-weighted mean path length
  double settled = 0, out = 0;
  auto land = [&](size_t i, double take) {
    const float w = weight ? std::clamp((*weight)[i], 0.0f, 1.0f) : 1.0f;
    const float before = bed.z[i];
    bed.z[i] = float(double(before) + double(w) * take);
    const float landed = bed.z[i] - before;  // what the float bed really took
    // A full-weight cell keeps no sediment; the sub-ulp remainder of the addition is round-off.
    sediment[i] = w >= 1.0f ? 0.0f : float(std::max(0.0, take - double(landed)));
    if (!deposit.empty()) deposit[i] += landed;  // settled sediment is loose: deposit layer
    settled += double(landed) * a;
  };
  auto pass_on = [&](size_t i, double pass, double len) {
    const size_t j = size_t(parent[i]);
    hops[j] = (carry[j] * hops[j] + pass * len) / (carry[j] + pass);
    carry[j] += pass;
  };
  // Upstream first (the reverse of the flood's order): each cell holds what it can, the rest runs on.
  for (auto it = visit.rbegin(); it != visit.rend(); ++it) {
    const size_t i = *it;
    const double load = double(std::max(0.0f, sediment[i])) + carry[i];
    if (dep[i] >= 0) {
      const size_t k = size_t(dep[i]);
      pool[k] += load;
      if (i != dep_first[k] || !(pool[k] > 0)) continue;
      // The depression's last cell: fill it flat to the level h that holds the pool, at most the spill.
      const auto& cells = dep_cells[k];
      std::vector<double> beds(cells.size());
      for (size_t c = 0; c < cells.size(); ++c) beds[c] = bed.z[cells[c]];
      std::sort(beds.begin(), beds.end());
      const double spill = level[i];
      double h = spill, below = 0;  // below: volume (m) under h over the cells lower than it
      for (size_t c = 0; c < beds.size(); ++c) {
        const double next = c + 1 < beds.size() ? std::min(beds[c + 1], spill) : spill;
        const double room = (next - beds[c]) * double(c + 1);
        if (below + room >= pool[k]) {
          h = beds[c] + (pool[k] - below) / double(c + 1);
          break;
        }
        below += room;
      }
      double held = 0;
      for (size_t c : cells) {
        const double take = std::max(0.0, h - double(bed.z[c]));
        held += take;
        land(c, take);
      }
      const double over = std::max(0.0, pool[k] - held);
      if (over > 0) pass_on(i, over, 1.0);  // spills over at the outlet
      continue;
    }
    if (!(load > 0)) continue;
    // Room: up to the ground it was cut from.
    const double room = std::max(0.0, double(initial[i]) - double(bed.z[i]));
    double take = std::min(load, room), pass = load - take, leave = 0;
    if (parent[i] < 0) {  // a border cell: the load leaves over an open border, settles at a closed one
      if (open_border) leave = pass;
      else take = load;
      pass = 0;
    } else if (reach > 0 && carry[i] > 0 && hops[i] >= reach) {  // it has run as far as it may
      take = load, pass = 0;
    }
    land(i, take);
    out += leave * a;
    if (pass > 0) {
      // The load passed on: the carry's (length + 1) and this cell's own sediment (length 1), weighted.
      const double own = std::max(0.0, load - carry[i]);
      const double from_carry = std::max(0.0, pass - own);
      pass_on(i, pass, (from_carry * (hops[i] + 1.0) + (pass - from_carry) * 1.0) / pass);
    }
  }
  if (drained) *drained = out;
  return settled;
}

int sediment_reach(long long substeps_run) {
  return int(std::clamp(std::ceil(0.5 * double(substeps_run)), 64.0, 1e6));
}

Heightfield Erosion::settled_bed(const std::vector<float>* weight) {
  Heightfield h = bed();
  ErosionState st = state();
  route_sediment(h, m->initial, st.sediment, st.deposit, weight,
                 m->p.boundary == ErosionBoundary::Open && !m->p.thermal_only, nullptr,
                 sediment_reach(m_steps * m_substeps));
  return h;
}

Heightfield erode(Device& dev, const Heightfield& terrain, const ErosionParams& params, int steps,
                  const std::vector<float>* weight, ErosionOutputs* outputs, const Progress& progress) {
  Erosion sim(dev, terrain, params, weight);
  const int recession = sim.recession_steps();
  // The progress bar covers both phases in proportion to their steps.
  const double share = double(steps) / std::max(1, steps + recession);
  sim.run(steps, scaled_progress(progress, 0.0, share));
  if (recession > 0) {
    sim.begin_recession();
    sim.run(recession, scaled_progress(progress, share, 1.0));
  }
  Heightfield out = sim.bed();
  ErosionState st = sim.state();
  double settled = 0, unsettled = 0, settle_drained = 0;
  const double a = terrain.georef.cell_x * terrain.georef.cell_y;
  if (params.settle) {
    settled = route_sediment(out, terrain.z, st.sediment, st.deposit, weight,
                             params.boundary == ErosionBoundary::Open && !params.thermal_only, &settle_drained,
                             sediment_reach(sim.steps_done() * sim.substeps()));
    for (float s : st.sediment) unsettled += double(s) * a;
  }
  // The bed is finite by construction; check anyway so that no NaN ever reaches a file.
  require_finite(out, kStage, "eroded bed");
  if (outputs) {
    auto field = [&](const std::vector<float>& v) {
      Heightfield h = out;
      h.z = v;
      return h;
    };
    outputs->water = field(st.water);
    outputs->sediment = field(st.sediment);
    std::vector<float> delta(out.size());
    for (size_t i = 0; i < delta.size(); ++i) delta[i] = out.z[i] - terrain.z[i];
    outputs->delta = field(delta);
    if (params.deposit_layer) outputs->deposit = field(st.deposit);
    outputs->totals = sim.totals();
    if (params.settle) {
      outputs->totals.sediment = unsettled;
      outputs->totals.settled = settled;
      outputs->totals.drained_sediment += settle_drained;  // the load that ran on out of the grid
    }
    outputs->substeps = sim.substeps();
    outputs->substep_dt = sim.substep_dt();
  }
  return out;
}

std::string erosion_program_options(const Device& dev, int width, const ErosionParams& params, bool weight) {
  // The work split (see XCHUNK in kernels/erosion.cl), as Erosion's constructor chooses it.
  int chunk = params.cells_per_item;
  if (chunk == 0) chunk = dev.info().launch == "wide" ? 32 : 0;
  chunk = int(round_up(size_t(std::max(chunk, 0)), 8));
  std::string opts;
  if (chunk > 0 && chunk < width) opts = fmt::format(" -DXCHUNK={}", chunk);
  if (params.boundary == ErosionBoundary::Open) opts += " -DOPEN_BORDER";
  if (weight) opts += " -DHAS_WEIGHT";
  if (params.deposit_layer) opts += " -DDEPOSIT_LAYER";
  if ((params.channel_diffusion > 0 || params.thermal_banks_only) && !params.thermal_only) opts += " -DCHANNEL_DIFFUSION";
  if ((params.channel_diffusion > 0 || params.thermal_banks_only) && !params.thermal_only) opts += " -DBANK_ROOM";
  if (params.thermal_banks_only && !params.thermal_only) opts += " -DBANK_THERMAL";
  if (params.creep_into_cuts && (params.channel_diffusion > 0 || params.thermal_banks_only) && !params.thermal_only)
    opts += " -DCREEP_INTO_CUTS";
  return opts;
}

}  // namespace terracl
