// SPDX-License-Identifier: Apache-2.0
// Public reconstruction API: uploads the problem (divergence computed on the device, constraint
// values scattered into the solution buffer), runs the multigrid launcher and reads the result.
#include <terracl/amplify.hpp>  // parallel_for
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>

#include "cl/row_launch.hpp"
#include <terracl/reconstruct.hpp>

#include "cl/workspace.hpp"
#include "reconstruct/hypre_solve.hpp"
#include "io/io_common.hpp"
#include "reconstruct/multigrid.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>

namespace terracl {
namespace {

// Host passes over the grid run in parallel_for over chunks of this many cells; grids below a few
// chunks stay on the calling thread (starting threads costs more than the pass).
constexpr size_t kHostChunk = size_t(1) << 16;
size_t host_chunks(size_t n) { return (n + kHostChunk - 1) / kHostChunk; }
int host_threads(size_t n) { return n < 4 * kHostChunk ? 1 : 0; }

void copy_floats(float* dst, const float* src, size_t n) {
  parallel_for(host_chunks(n), host_threads(n), [&](size_t c0, size_t c1) {
    const size_t b = c0 * kHostChunk, e = std::min(n, c1 * kHostChunk);
    std::copy(src + b, src + e, dst + b);
  });
}

double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

// The phase breakdown (TERRACL_PHASES or TERRACL_MG_PROFILE): mark() drains the queue and books
// the time since the previous mark under `name`. Off, it costs nothing and adds no waits.
class PhaseClock {
 public:
  PhaseClock(double t0, std::vector<std::pair<std::string, double>>& out)
      : m_on(std::getenv("TERRACL_PHASES") || std::getenv("TERRACL_MG_PROFILE")), m_last(t0), m_out(out) {}
  bool on() const { return m_on; }
  void mark(Device& d, const char* name) {
    if (!m_on) return;
    d.queue().finish();
    add(name, now_ms() - m_last);
  }
  // A phase timed elsewhere (the multigrid launcher's hierarchy, cycles, refinement).
  void add(const char* name, double ms) {
    if (!m_on) return;
    m_last = now_ms();
    for (auto& [n, v] : m_out)
      if (n == name) {
        v += ms;
        return;
      }
    m_out.emplace_back(name, ms);
  }

 private:
  bool m_on;
  double m_last;
  std::vector<std::pair<std::string, double>>& m_out;
};

// The level-0 buffers of one solve: taken from the device's workspace (cached between solves of
// one grid size, cl/workspace.hpp) and put back at the end, or plain buffers when the cache is off.
class SolveBuffers {
 public:
  SolveBuffers(Device& d, int W, int H)
      : m_d(d), m_w(W), m_h(H), m_cache(workspace_enabled()), m_pin(use_pinned_staging(d)) {
    if (m_cache) m_ws = workspace_for(d);
  }
  SolveBuffers(const SolveBuffers&) = delete;
  SolveBuffers& operator=(const SolveBuffers&) = delete;
  ~SolveBuffers() {
    put_back_all_but("");
    if (m_cache)
      for (auto& [slot, s] : m_staging) m_ws->put_pinned(m_w, m_h, slot, std::move(s));
  }
  /// Whether the large transfers go through pinned host staging (cl/workspace.hpp).
  bool pinned() const { return m_pin; }
  /// Pinned host staging of `bytes` for `slot`, kept for the whole solve.
  PinnedStaging& staging(const std::string& slot, size_t bytes) {
    for (auto& [name, s] : m_staging)
      if (name == slot && s->bytes() == bytes) return *s;
    auto s = m_cache ? m_ws->take_pinned(m_d, m_w, m_h, slot, bytes) : std::make_shared<PinnedStaging>(m_d, bytes);
    m_staging.emplace_back(slot, s);
    return *s;
  }
  /// Enqueues the upload of `bytes` from host `src` into `dst`: through the pinned staging `slot`
  /// (copied there in threads) when pinned(), else straight from `src`. `blocking` where the
  /// staging is reused before the queue drains.
  void upload(const cl::Buffer& dst, const float* src, size_t bytes, const std::string& slot, bool blocking = false) {
    if (!m_pin) {
      m_d.queue().enqueueWriteBuffer(dst, blocking ? CL_TRUE : CL_FALSE, 0, bytes, src);
      return;
    }
    PinnedStaging& st = staging(slot, bytes);
    copy_floats(st.data(), src, bytes / sizeof(float));
    m_d.queue().enqueueWriteBuffer(dst, blocking ? CL_TRUE : CL_FALSE, 0, bytes, st.data());
  }
  /// Returns every taken buffer except `keep` to the cache (idle there, the memory-pressure path
  /// of Device::buffer can release them).
  void put_back_all_but(const std::string& keep1, const std::string& keep2 = "") {
    std::vector<std::pair<std::string, cl::Buffer>> kept;
    for (auto& [slot, b] : m_taken)
      if (slot == keep1 || slot == keep2) kept.emplace_back(slot, std::move(b));
      else m_ws->put(m_w, m_h, slot, std::move(b));
    m_taken.swap(kept);
  }
  cl::Buffer take(const char* slot, size_t bytes, cl_mem_flags flags, const char* what) {
    if (!m_cache) return m_d.buffer(bytes, flags, what);
    cl::Buffer b = m_ws->take(m_d, m_w, m_h, slot, bytes, flags, what, &m_reused);
    m_taken.emplace_back(slot, b);
    return b;
  }
  /// Bytes of cached buffers this solve reuses: counted in the device's allocation before the
  /// solve started, so the peak figure adds them back.
  uint64_t reused() const { return m_reused; }

 private:
  Device& m_d;
  int m_w, m_h;
  bool m_cache, m_pin;
  std::shared_ptr<Workspace> m_ws;
  uint64_t m_reused = 0;
  std::vector<std::pair<std::string, std::shared_ptr<PinnedStaging>>> m_staging;
  std::vector<std::pair<std::string, cl::Buffer>> m_taken;
};

using RhsMaker = std::function<void(Device&, cl::Buffer& g, PhaseClock& clk, SolveBuffers& bufs)>;

// Throws a clear error for a grid, cell size, option or warm start the solver cannot take.
void check_solve_inputs(int W, int H, double cx, double cy, const ConstraintSet& cin, const SolverOptions& o) {
  if (W < 1 || H < 1) fail("reconstruct", "empty input grid");
  if (!(cx > 0) || !(cy > 0) || !std::isfinite(cx) || !std::isfinite(cy))
    fail("reconstruct", "cell size must be positive and finite, got {} x {} m", cx, cy);
  if (!(o.tolerance > 0)) fail("reconstruct", "tolerance must be positive, got {}", o.tolerance);
  if (!(o.refine_tolerance > 0)) fail("reconstruct", "refine tolerance must be positive, got {}", o.refine_tolerance);
  if (o.max_cycles < 1) fail("reconstruct", "max cycles must be at least 1, got {}", o.max_cycles);
  if (o.pre_smooth < 0 || o.post_smooth < 0 || o.pre_smooth + o.post_smooth < 1)
    fail("reconstruct", "smoothing sweeps must be >= 0 with at least one in total");
  if (o.initial) {
    if (o.initial->width != W || o.initial->height != H)
      fail("reconstruct", "initial/warm-start heightfield is {}x{}, the input is {}x{}", o.initial->width,
           o.initial->height, W, H);
    require_finite(*o.initial, "reconstruct", "the initial/warm-start heightfield");
  }
  if (cin.width() != 0 && (cin.width() != W || cin.height() != H))
    fail("reconstruct", "constraints are {}x{}, the input is {}x{}", cin.width(), cin.height(), W, H);
  if (size_t(W) * size_t(H) > size_t(UINT32_MAX)) fail("reconstruct", "grid {}x{} has too many cells", W, H);
}

// Hard cells as a sparse row-major list (index, resolved value), with the border added when asked.
struct HardCells {
  std::vector<uint32_t> index;
  std::vector<float> value;
};
HardCells hard_cells_of(int W, int H, const ConstraintSet& cin, const SolverOptions& o) {
  HardCells hc;
  if (o.dirichlet_border) {
    if (!o.initial) fail("reconstruct", "a Dirichlet border needs the initial heightfield for its values");
    ConstraintSet c = cin.width() ? cin : ConstraintSet(W, H);
    c.add_border(*o.initial);
    c.hard_cells(hc.index, hc.value);
  } else if (cin.width()) {
    cin.hard_cells(hc.index, hc.value);
  }
  return hc;
}

// The mean a solve without hard cells is shifted to: the asked one, else the source's, else the
// warm start's.
double target_mean(const SolverOptions& o, double source_mean) {
  if (o.mean) return *o.mean;
  if (std::isfinite(source_mean)) return source_mean;
  if (!o.initial) return 0;
  double s = 0;
  for (float v : o.initial->z) s += v;
  return s / double(o.initial->size());
}

// Device level 0 of the problem: u the warm start (or 0) as deviation from m, g = -f from make_rhs,
// then the hard cells scattered from the sparse list (u = value - m, g = NaN); a singular problem's
// right-hand side projected onto the range of the pure-Neumann operator. Returns the peak bytes.
uint64_t upload_level0(Device& d, mg::Problem& p, const HardCells& hc, double m, const RhsMaker& make_rhs,
                       const SolverOptions& o, PhaseClock& clk, SolveBuffers& bufs, AllocationScope& scope) {
  const int W = p.width, H = p.height;
  const size_t N = size_t(W) * H, bytes = N * sizeof(float), hard = hc.index.size();
  cl::CommandQueue& q = d.queue();
  uint64_t peak = 0;
  p.u = bufs.take("u", bytes, CL_MEM_READ_WRITE, "reconstruction solution");
  p.g = bufs.take("g", bytes, CL_MEM_READ_WRITE, "reconstruction right-hand side");
  if (o.initial) {
    bufs.upload(p.u, o.initial->z.data(), bytes, "stage x", true);  // the staging is reused next
    clk.mark(d, "upload");
    cl::Kernel sh = d.kernel("multigrid", "shift_level0");
    set_args(sh, p.u, W, H, float(m));
    launch_rows(d, sh, size_t(H));
  } else {
    d.fill(p.u, 0.0f, 0, N);
  }
  clk.mark(d, "device init");
  make_rhs(d, p.g, clk, bufs);
  clk.mark(d, "device init");
  peak = std::max<uint64_t>(peak, scope.live());
  if (hard) {
    cl::Buffer bi = bufs.take("hard index", hard * sizeof(uint32_t), CL_MEM_READ_ONLY, "hard cell indices");
    cl::Buffer bv = bufs.take("hard value", hard * sizeof(float), CL_MEM_READ_ONLY, "hard cell values");
    q.enqueueWriteBuffer(bi, CL_FALSE, 0, hard * sizeof(uint32_t), hc.index.data());
    q.enqueueWriteBuffer(bv, CL_FALSE, 0, hard * sizeof(float), hc.value.data());
    clk.mark(d, "upload");
    const int chunk = 4096;
    cl::Kernel sc = d.kernel("multigrid", "scatter_hard");
    set_args(sc, p.u, p.g, bi, bv, int(hard), chunk, float(m));
    launch_rows(d, sc, (hard + chunk - 1) / chunk);
    peak = std::max<uint64_t>(peak, scope.live());
  }
  q.finish();  // the gradient and hard-list buffers go back to the (releasable) cache
  bufs.put_back_all_but("u", "g");
  if (p.singular) {
    // Project onto the range of the pure-Neumann operator: the mean of f must vanish.
    cl::Buffer rows = d.buffer(size_t(H) * sizeof(float), CL_MEM_READ_WRITE, "row sums");
    cl::Kernel k = d.kernel("multigrid", "row_sums");
    set_args(k, p.g, W, H, rows);
    launch_rows(d, k, size_t(H));
    std::vector<float> rs(static_cast<size_t>(H));
    q.enqueueReadBuffer(rows, CL_TRUE, 0, rs.size() * sizeof(float), rs.data());
    double s = 0;
    for (float v : rs) s += v;
    const double mean = s / double(N);
    // Launched even when the mean is 0 (the same bits then): a small symmetric problem, such as
    // the warm-up's runs (apps/warm_kernels.cpp), must compile it for a user's first solve.
    cl::Kernel sh = d.kernel("multigrid", "shift_free");
    set_args(sh, p.g, W, H, float(mean));
    launch_rows(d, sh, size_t(H));
  }
  clk.mark(d, "device init");
  return peak;
}

// The result heights from the solution as read back (`src`): shifted to the reference level (or,
// singular, to the target mean), hard cells bit-exact, and every value checked finite.
void finish_heights(Heightfield& h, const float* src, size_t N, int W, double shift, const HardCells& hc) {
  const size_t hard = hc.index.size();
  // Element-wise passes in threads: every cell's value is computed alone, so the result does not
  // depend on the thread count (the singular mean is one sequential sum for that reason).
  std::vector<char> chunk_finite(host_chunks(N), 1);
  parallel_for(chunk_finite.size(), host_threads(N), [&](size_t c0, size_t c1) {
    for (size_t c = c0; c < c1; ++c) {
      bool f = true;
      float* z = h.z.data();
      for (size_t i = c * kHostChunk, e = std::min(N, i + kHostChunk); i < e; ++i) {
        z[i] = float(double(src[i]) + shift);
        f &= std::isfinite(z[i]);
      }
      chunk_finite[c] = f;
    }
  });
  parallel_for(host_chunks(hard), host_threads(hard), [&](size_t c0, size_t c1) {
    for (size_t k = c0 * kHostChunk, e = std::min(hard, c1 * kHostChunk); k < e; ++k)
      h.z[hc.index[k]] = hc.value[k];  // hard cells bit-exact (the indices are distinct)
  });
  bool finite = true;
  for (char f : chunk_finite) finite &= f != 0;
  for (size_t i = 0; !finite && i < N; ++i)
    if (!std::isfinite(h.z[i]))
      fail("reconstruct", "the solver produced a non-finite value at cell ({}, {}): NaN/Inf in the input, or values too large for float32",
           i % W, i / W);
}

// One reconstruction whatever its input (a gradient field, device buffers or a divergence):
// checks, hard cells, the level-0 upload, the multigrid (or hypre) solve, the read-back and finish.
ReconstructResult solve_common(Device& d, int W, int H, const Georef& georef, const Metadata& meta,
                               double source_mean, const RhsMaker& make_rhs, const ConstraintSet& cin,
                               const SolverOptions& o, const hypre::RowDivergence& row_div = {}) {
  const double t0 = now_ms();
  const double cx = georef.cell_x, cy = georef.cell_y;
  check_solve_inputs(W, H, cx, cy, cin, o);
  const HardCells hc = hard_cells_of(W, H, cin, o);
  const double t_vals = now_ms();
  std::vector<std::pair<std::string, double>> phases;
  PhaseClock clk(t0, phases);
  clk.add("host constraints", t_vals - t0);
  const size_t hard = hc.index.size();
  double hard_sum = 0;
  for (float v : hc.value) hard_sum += v;
  const bool singular = hard == 0;
  const double target = target_mean(o, source_mean);
  if (o.solver == Solver::Hypre) {
    // The whole problem is in memory here; reconstruct_hypre_files reads it by bands instead.
    if (!row_div) fail("reconstruct", "the hypre solver needs the problem on the host");
    return hypre::solve(W, H, georef, meta, hypre::whole_problem(W, row_div, hc.index, hc.value, o.initial),
                        target, o);
  }
  // Work with the deviation from a reference level: float32 keeps more digits for the solve.
  const double m = singular ? target : hard_sum / double(hard);

  ReconstructResult res;
  res.device = d.info().name;
  res.cycle = o.cycle;
  res.smoother = o.smoother;
  res.hard_cells = hard;
  AllocationScope scope;  // this solve's own buffers (the peak figure)
  mg::Problem p;
  p.width = W;
  p.height = H;
  p.cell_x = cx;
  p.cell_y = cy;
  p.singular = singular;
  const size_t N = size_t(W) * H, bytes = N * sizeof(float);
  // The solution is read straight into the result (no second N-float array).
  std::vector<float>& out = res.height.z;
  out.resize(N);
  SolveBuffers bufs(d, W, H);
  const float* src = out.data();  // the solution as read back (out itself, or pinned staging)
  try {
    cl::CommandQueue& q = d.queue();
    const uint64_t peak = upload_level0(d, p, hc, m, make_rhs, o, clk, bufs, scope);
    const double t_setup0 = now_ms() - t0;
    if (std::getenv("TERRACL_MG_PROFILE"))
      std::fprintf(stderr, "host constraints %.1f ms, upload+divergence+init %.1f ms\n", t_vals - t0, now_ms() - t_vals);
    p.phases = clk.on();
    mg::SolveStats st = mg::solve(d, p, o, scope);
    const double t_solved = now_ms();
    clk.add("hierarchy", st.setup_ms);
    clk.add("cycles", st.cycles_ms);
    clk.add("refinement", st.refine_ms);
    clk.add("solver other", t_solved - t0 - t_setup0 - st.setup_ms - st.cycles_ms - st.refine_ms);
    // Pinned: the read lands in the staging and finish_heights copies it into the result (the
    // copy is that pass's own; no extra one).
    if (bufs.pinned()) {
      src = bufs.staging("stage x", bytes).data();
      q.enqueueReadBuffer(p.u, CL_TRUE, 0, bytes, const_cast<float*>(src));
    } else {
      q.enqueueReadBuffer(p.u, CL_TRUE, 0, bytes, out.data());
    }
    clk.mark(d, "read-back");
    res.cycles = st.cycles;
    res.residuals = st.residuals;
    res.converged = st.converged;
    res.stagnated = st.stagnated;
    res.levels = st.levels;
    res.refinement = st.refinement;
    res.refine_cycles = st.refine_cycles;
    res.refine_residuals = st.refine_residuals;
    res.setup_ms = t_setup0 + st.setup_ms;
    res.solve_ms = t_solved - t0 - res.setup_ms;
    res.device_bytes = std::max(peak, st.peak_bytes) + bufs.reused();
  } catch (const cl::Error& e) {
    fail("reconstruct", "{}", describe(e));
  }

  Heightfield& h = res.height;
  h.width = W;
  h.height = H;
  h.georef = georef;
  h.georef.vertical_units = "m";
  h.metadata = meta;
  h.metadata.erase("terracl:gradient");
  double shift = m;
  if (singular) {
    double s = 0;
    for (size_t i = 0; i < N; ++i) s += src[i];
    shift = target - s / double(N);
  }
  finish_heights(h, src, N, W, shift, hc);
  clk.mark(d, "host finish");
  res.phases_ms = std::move(phases);
  res.total_ms = now_ms() - t0;
  return res;
}

}  // namespace

Cycle parse_cycle(const std::string& s) {
  if (s == "v") return Cycle::V;
  if (s == "w") return Cycle::W;
  if (s == "fmg") return Cycle::Fmg;
  if (s == "cascade") return Cycle::Cascade;
  fail("reconstruct", "unknown cycle '{}' (v|w|fmg|cascade)", s);
}

Smoother parse_smoother(const std::string& s) {
  if (s == "rbgs") return Smoother::Rbgs;
  if (s == "jacobi") return Smoother::Jacobi;
  fail("reconstruct", "unknown smoother '{}' (rbgs|jacobi)", s);
}

const char* cycle_name(Cycle c) {
  switch (c) {
    case Cycle::V: return "v";
    case Cycle::W: return "w";
    case Cycle::Fmg: return "fmg";
    case Cycle::Cascade: return "cascade";
  }
  return "?";
}

const char* smoother_name(Smoother s) { return s == Smoother::Rbgs ? "rbgs" : "jacobi"; }

Refinement parse_refinement(const std::string& s) {
  if (s == "off") return Refinement::Off;
  if (s == "auto") return Refinement::Auto;
  if (s == "device") return Refinement::Device;
  if (s == "host") return Refinement::Host;
  fail("reconstruct", "unknown refinement '{}' (off|auto|device|host)", s);
}

Solver parse_solver(const std::string& s) {
  if (s == "multigrid") return Solver::Multigrid;
  if (s == "hypre") return Solver::Hypre;
  fail("reconstruct", "unknown solver '{}' (multigrid|hypre)", s);
}

const char* solver_name(Solver s) { return s == Solver::Hypre ? "hypre" : "multigrid"; }

const char* refinement_name(Refinement r) {
  switch (r) {
    case Refinement::Off: return "off";
    case Refinement::Auto: return "auto";
    case Refinement::Device: return "device";
    case Refinement::Host: return "host";
  }
  return "?";
}

std::vector<std::pair<int, int>> multigrid_levels(int width, int height) {
  std::vector<std::pair<int, int>> v{{width, height}};
  do {
    const auto [w, h] = v.back();
    v.push_back({w / 2 + 1, h / 2 + 1});
  } while (int64_t(v.back().first) * v.back().second > 64);
  return v;
}

nlohmann::json ReconstructResult::to_json() const {
  nlohmann::json j = {{"device", device},
          {"width", height.width},
          {"height", height.height},
          {"cycle", cycle_name(cycle)},
          {"smoother", smoother_name(smoother)},
          {"levels", levels},
          {"hard_cells", hard_cells},
          {"cycles", cycles},
          {"relative_residuals", residuals},
          {"final_relative_residual", residuals.empty() ? 0.0 : residuals.back()},
          {"converged", converged},
          {"stagnated_at_float32_floor", stagnated},
          {"setup_ms", setup_ms},
          {"solve_ms", solve_ms},
          {"total_ms", total_ms},
          {"device_bytes", device_bytes},
          {"refinement", refinement},
          {"refine_cycles", refine_cycles},
          {"refine_relative_residuals", refine_residuals},
          {"solver", solver},
          {"mpi_ranks", ranks}};
  if (!phases_ms.empty()) {
    nlohmann::json ph = nlohmann::json::object();
    for (const auto& [n, v] : phases_ms) ph[n] = v;
    j["phases_ms"] = ph;
  }
  return j;
}

ReconstructResult reconstruct(Device& d, const GradientField& gin, const ConstraintSet& c, const SolverOptions& o) {
  const int W = gin.width, H = gin.height;
  if (gin.gx.size() != size_t(W) * H || gin.gy.size() != size_t(W) * H)
    fail("reconstruct", "gradient arrays do not match its {}x{} size", W, H);
  // The first non-finite cell in row-major order, found in threads (each chunk its own first).
  std::vector<size_t> first_bad(host_chunks(gin.size()), SIZE_MAX);
  parallel_for(first_bad.size(), host_threads(gin.size()), [&](size_t c0, size_t c1) {
    for (size_t c = c0; c < c1; ++c)
      for (size_t i = c * kHostChunk, e = std::min(gin.size(), i + kHostChunk); i < e; ++i)
        if (!std::isfinite(gin.gx[i]) || !std::isfinite(gin.gy[i])) {
          first_bad[c] = i;
          break;
        }
  });
  for (size_t i : first_bad)
    if (i != SIZE_MAX)
      fail("reconstruct", "gradient has a NaN/Inf value at cell ({}, {})", i % size_t(W), i / size_t(W));
  GradientField converted;
  const GradientField* g = &gin;
  if (gradient_format(gin) == GradientFormat::Central) {
    converted = to_staggered(d, gin);
    g = &converted;
  }
  RhsMaker rhs = [&](Device& dev, cl::Buffer& out, PhaseClock& clk, SolveBuffers& bufs) {
    const size_t bytes = g->size() * sizeof(float);
    cl::Buffer gx = bufs.take("gx", bytes, CL_MEM_READ_ONLY, "gradient gx");
    cl::Buffer gy = bufs.take("gy", bytes, CL_MEM_READ_ONLY, "gradient gy");
    bufs.upload(gx, g->gx.data(), bytes, "stage x");
    bufs.upload(gy, g->gy.data(), bytes, "stage y");
    clk.mark(dev, "upload");
    enqueue_divergence(dev, gx, gy, out, g->width, g->height, g->georef.cell_x, g->georef.cell_y, -1.0f);
  };
  // The same backward differences as kernels/gradient.cl's divergence, in double (hypre).
  hypre::RowDivergence row_div = [g](int y, double* f) {
    const int W = g->width, H = g->height;
    const double icx = 1.0 / g->georef.cell_x, icy = 1.0 / g->georef.cell_y;
    const size_t o = size_t(y) * W;
    for (int x = 0; x < W; ++x) {
      const double ex = x + 1 < W ? g->gx[o + x] : 0.0, wx = x > 0 ? g->gx[o + x - 1] : 0.0;
      const double sy = y + 1 < H ? g->gy[o + x] : 0.0, ny = y > 0 ? g->gy[o - W + x] : 0.0;
      f[x] = (ex - wx) * icx + (sy - ny) * icy;
    }
  };
  return solve_common(d, W, H, g->georef, g->metadata, g->mean_elevation, rhs, c, o, row_div);
}

ReconstructResult reconstruct_device(Device& d, const cl::Buffer& gx, const cl::Buffer& gy, const GradientField& like,
                                     const ConstraintSet& c, const SolverOptions& o) {
  if (gradient_format(like) == GradientFormat::Central)
    fail("reconstruct", "device gradients must be staggered (convert central gradients first)");
  const size_t need = size_t(like.width) * size_t(like.height) * sizeof(float);
  if (gx.getInfo<CL_MEM_SIZE>() < need || gy.getInfo<CL_MEM_SIZE>() < need)
    fail("reconstruct", "device gradient buffers are smaller than {}x{} floats", like.width, like.height);
  if (o.solver == Solver::Hypre) {  // hypre solves on the host: bring the field back
    GradientField g = like;
    g.gx.resize(like.width * size_t(like.height));
    g.gy.resize(g.gx.size());
    try {
      d.queue().enqueueReadBuffer(gx, CL_FALSE, 0, need, g.gx.data());
      d.queue().enqueueReadBuffer(gy, CL_TRUE, 0, need, g.gy.data());
    } catch (const cl::Error& e) {
      fail("reconstruct", "{}", describe(e));
    }
    return reconstruct(d, g, c, o);
  }
  RhsMaker rhs = [&](Device& dev, cl::Buffer& out, PhaseClock&, SolveBuffers&) {
    enqueue_divergence(dev, gx, gy, out, like.width, like.height, like.georef.cell_x, like.georef.cell_y, -1.0f);
  };
  return solve_common(d, like.width, like.height, like.georef, like.metadata, like.mean_elevation, rhs, c, o);
}

ReconstructResult reconstruct_divergence(Device& d, const Heightfield& f, const ConstraintSet& c,
                                         const SolverOptions& o) {
  require_finite(f, "reconstruct", "the divergence");
  RhsMaker rhs = [&](Device& dev, cl::Buffer& out, PhaseClock& clk, SolveBuffers& bufs) {
    const size_t n = f.size();
    std::vector<float> neg_host;
    float* neg = nullptr;
    if (bufs.pinned()) {
      neg = bufs.staging("stage x", n * sizeof(float)).data();
    } else {
      neg_host.resize(n);
      neg = neg_host.data();
    }
    parallel_for(host_chunks(n), host_threads(n), [&](size_t c0, size_t c1) {
      for (size_t i = c0 * kHostChunk, e = std::min(n, c1 * kHostChunk); i < e; ++i) neg[i] = -f.z[i];
    });
    dev.queue().enqueueWriteBuffer(out, CL_TRUE, 0, n * sizeof(float), neg);
    clk.mark(dev, "upload");
  };
  hypre::RowDivergence row_div = [&f](int y, double* out) {
    const float* row = f.z.data() + size_t(y) * f.width;
    for (int x = 0; x < f.width; ++x) out[x] = row[x];
  };
  Georef geo = f.georef;
  return solve_common(d, f.width, f.height, geo, f.metadata, std::numeric_limits<double>::quiet_NaN(), rhs, c, o,
                      row_div);
}

}  // namespace terracl
