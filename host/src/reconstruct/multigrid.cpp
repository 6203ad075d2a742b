// SPDX-License-Identifier: Apache-2.0
// Multigrid hierarchy and cycles. See kernels/multigrid.cl for the discretisation and
// docs/reconstruct.md for the design choices and measurements.
#include "reconstruct/multigrid.hpp"
#include "reconstruct/refine.hpp"
#include <terracl/launch.hpp>
#include "cl/row_launch.hpp"
#include "cl/workspace.hpp"

#include <terracl/error.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

namespace terracl::mg {
namespace {

constexpr int64_t kFourColourCells = 128 * 128;
// The fused coarse cycle (kernels/multigrid_coarse.cl) takes over at the first level of at most
// this many cells whose e and r (all levels below included) fit the device's local memory. One
// work-group does it all, so on a CPU device the bound keeps big levels on both cores; 65^2 is the
// 1025^2 / 4097^2 hierarchies' level (measured: docs/performance.md).
constexpr int64_t kFusedMaxCells = 72 * 72;
// Work-items of the fused launch: 128 on GPUs (4 warps: the zebra rows of a 65^2 level are 33);
// 16 on CPU devices (rows shape), where the work-items of a group run one after the other on
// one core and idle ones still cost their turn at every barrier (oclgrind: 4x the time at 256).
constexpr size_t kFusedGroupWide = 128, kFusedGroupRows = 16;
// FMG V-cycles on each coarse level before moving up. Two cost ~1/3 of a fine V-cycle more than
// one and bring the finest level to ~1e-6 after FMG + one V-cycle at 1025^2-4097^2 (one saves no
// fine cycle: 1.5e-6 after FMG + V, so a second fine V-cycle was needed).
constexpr int kFmgCyclesPerLevel = 2;

// Stop once the level-0 residual is within this factor of its float32 rounding floor (measured:
// the residual levels off at 1.3-1.4x the estimate; at 2x one more V-cycle gains less than 1.5x).
constexpr double kFloorFactor = 2.0;

// TERRACL_MG_PROFILE=1: wait after every kernel and print the time per kernel (=2: per kernel and
// launch size, i.e. per level; development aid;
// the waits themselves cost 25-50 us each on PoCL).
bool profiling() {
  static const bool on = std::getenv("TERRACL_MG_PROFILE") != nullptr;
  return on;
}
struct ProfileEntry {
  double ms = 0, items = 0;
  int calls = 0;
};
std::map<std::string, ProfileEntry>& profile() {
  static std::map<std::string, ProfileEntry> p;
  return p;
}
void print_profile() {
  int launches = 0;
  for (auto& [k, v] : profile()) {
    std::fprintf(stderr, "%-22s %9.2f ms %5d calls %8.2f ns/item\n", k.c_str(), v.ms, v.calls, 1e6 * v.ms / v.items);
    launches += v.calls;
  }
  std::fprintf(stderr, "%-22s %9s    %5d launches\n", "total", "", launches);
}

/// The fused coarse cycle runs on devices of the wide launch shape (GPUs), where it saves ~480
/// launches per 1025^2 solve. On CPU devices both paths take the same time (docs/performance.md),
/// and PoCL needs ~10 s to compile the fused kernel's barriers in loops on first use, so they keep
/// the multi-launch path. TERRACL_MG_FUSED=1 / =0 forces it on / off (comparisons, tests).
bool fused_allowed(const DeviceInfo& info) {
  const char* v = std::getenv("TERRACL_MG_FUSED");
  if (v && std::string(v) == "0") return false;
  if (v && std::string(v) == "1") return true;
  return info.launch == "wide";
}

struct Level {
  int W = 0, H = 0;
  cl::Buffer e, r, st, tmp;  // level 0 uses Problem::u/g instead of e/r
};

double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

class Solver {
 public:
  Solver(Device& d, Problem& p, const SolverOptions& o, const AllocationScope& scope)
      : m_d(d), m_q(d.queue()), m_p(p), m_o(o), m_scope(scope), m_ws(d, p.width, p.height) {
    profile().clear();
    m_wx = float(1.0 / (p.cell_x * p.cell_x));
    m_wy = float(1.0 / (p.cell_y * p.cell_y));
    auto k = [&](const char* n) { return d.kernel("multigrid", n); };
    m_rb0 = k("smooth_rb0");
    m_jac0 = k("jacobi0");
    m_rr0 = k("residual_restrict0");
    m_pc0 = k("prolong_correct0");
    m_norm0 = k("residual_norm0");
    m_rhs0 = k("rhs_norm0");
    m_z9 = k("smooth9");
    m_jac9 = k("jacobi9");
    m_rr9 = k("residual_restrict9");
    m_pc9 = k("prolong_correct9");
    m_cs = k("coarse_solve");
    m_rows = m_ws.take("mg rows", 2 * sizeof(float) * size_t(p.height), CL_MEM_READ_WRITE, "residual rows");
    m_rows_host.resize(2 * size_t(p.height));
  }

  // Buffers reused from the workspace were allocated before the solve: added back.
  void track() {
    m_stats.peak_bytes = std::max<uint64_t>(m_stats.peak_bytes, m_scope.live() + m_ws.reused());
  }
  /// The hierarchy's buffers (cached between solves of one grid size, cl/workspace.hpp); the
  /// refinement takes its vectors from the same.
  WorkspaceBuffers& buffers() { return m_ws; }

  void build() {
    const auto dims = multigrid_levels(m_p.width, m_p.height);
    m_levels.resize(dims.size());
    const bool jac = m_o.smoother == Smoother::Jacobi;
    for (size_t l = 0; l < dims.size(); ++l) {
      Level& L = m_levels[l];
      L.W = dims[l].first;
      L.H = dims[l].second;
      if (l == 0) {
        if (jac) L.tmp = m_ws.take("mg tmp 0", size_t(L.W) * L.H * sizeof(float), CL_MEM_READ_WRITE, "multigrid level 0 Jacobi buffer");
        continue;
      }
      // Coarse levels carry a ghost frame of zeros (see kernels/multigrid.cl).
      const size_t n = size_t(L.W + 2) * (L.H + 2) * sizeof(float);
      // Zeroed whether fresh or reused: the ghost frames must be zero.
      auto zeroed = [&](size_t bytes, const char* what) {
        cl::Buffer b = m_ws.take(fmt::format("mg {} {}", what, l), bytes, CL_MEM_READ_WRITE, what);
        m_d.fill(b, 0.0f, 0, bytes / sizeof(float));
        return b;
      };
      L.e = zeroed(n, "multigrid correction");
      L.r = zeroed(n, "multigrid residual");
      L.st = zeroed(6 * n, "multigrid coarse operator");
      if (jac) L.tmp = zeroed(n, "multigrid Jacobi buffer");
    }
    track();
    // Galerkin operators, finest to coarsest, all enqueued.
    cl::Kernel g0 = m_d.kernel("multigrid", "galerkin0");
    cl::Kernel g9 = m_d.kernel("multigrid", "galerkin9");
    for (size_t l = 1; l < m_levels.size(); ++l) {
      const Level &F = m_levels[l - 1], &C = m_levels[l];
      if (l == 1) {
        set_args(g0, m_p.g, F.W, F.H, m_wx, m_wy, C.st, C.W, C.H);
        run(g0, C.H, double(C.W) * C.H, C.W);
      } else {
        set_args(g9, F.st, F.W, F.H, C.st, C.W, C.H);
        run(g9, C.H, double(C.W) * C.H, C.W);
      }
    }
    // Coarsest level: pseudo-inverse on the host, in double (handles the singular Neumann case
    // and dead nodes).
    const Level& C = m_levels.back();
    const int n = C.W * C.H;
    const size_t N = size_t(C.W + 2) * (C.H + 2);
    std::vector<float> st(5 * N);
    m_q.enqueueReadBuffer(C.st, CL_TRUE, 0, st.size() * sizeof(float), st.data());
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    for (int y = 0; y < C.H; ++y)
      for (int x = 0; x < C.W; ++x) {
        const int i = y * C.W + x;
        const size_t gi = size_t(y + 1) * (C.W + 2) + x + 1;
        A(i, i) = st[gi];
        auto link = [&](int k, int xx, int yy) {
          if (xx < 0 || yy < 0 || xx >= C.W || yy >= C.H) return;
          const int j = yy * C.W + xx;
          A(i, j) -= st[size_t(k) * N + gi];
          A(j, i) -= st[size_t(k) * N + gi];
        };
        link(1, x + 1, y);
        link(2, x, y + 1);
        link(3, x + 1, y + 1);
        link(4, x - 1, y + 1);
      }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A);
    const double top = es.eigenvalues().cwiseAbs().maxCoeff();
    Eigen::VectorXd inv = es.eigenvalues();
    for (int i = 0; i < n; ++i) inv(i) = std::abs(inv(i)) > 1e-5 * top && top > 0 ? 1.0 / inv(i) : 0.0;
    Eigen::MatrixXd P = es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
    m_pinv_host.resize(size_t(n) * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) m_pinv_host[size_t(i) * n + j] = float(P(i, j));
    m_pinv = m_ws.take("mg pinv", m_pinv_host.size() * sizeof(float), CL_MEM_READ_ONLY, "coarsest pseudo-inverse");
    m_q.enqueueWriteBuffer(m_pinv, CL_FALSE, 0, m_pinv_host.size() * sizeof(float), m_pinv_host.data());
    track();
    m_stats.levels = int(m_levels.size());
    if (fused_allowed(m_d.info()) && m_o.smoother == Smoother::Rbgs) build_fused();
  }

  // The fused coarse cycle: the first level l >= 1 that is small enough (kFusedMaxCells, zebra
  // smoothing) and whose levels l.. fit local memory next to the kernel's own. Their stencil planes
  // are packed into one buffer (a kernel takes a fixed number of buffers).
  void build_fused() {
    m_fk = m_d.kernel("multigrid_coarse", "coarse_cycle");
    const cl::Device& dev = m_d.device();
    const uint64_t kernel_local = m_fk.getWorkGroupInfo<CL_KERNEL_LOCAL_MEM_SIZE>(dev);
    const uint64_t avail = m_d.info().local_mem > kernel_local ? m_d.info().local_mem - kernel_local : 0;
    auto ghosted = [&](size_t l) { return int64_t(m_levels[l].W + 2) * (m_levels[l].H + 2); };
    const size_t L = m_levels.size();
    uint64_t below = 0;  // local bytes of levels l..L-1 (their e)
    size_t top = L;
    for (size_t l = L; l-- > 1;) {
      below += sizeof(float) * uint64_t(ghosted(l));
      if (int64_t(m_levels[l].W) * m_levels[l].H > std::min(kFusedMaxCells, kFourColourCells - 1) || below > avail) break;
      top = l;
    }
    if (top >= L) return;
    std::vector<cl_int> meta;
    size_t st_floats = 0, lm_floats = 0;
    for (size_t l = top; l < L; ++l) {
      meta.insert(meta.end(), {m_levels[l].W, m_levels[l].H, cl_int(st_floats), cl_int(lm_floats)});
      st_floats += 5 * size_t(ghosted(l));
      lm_floats += size_t(ghosted(l));
    }
    m_fst = m_ws.take("mg fused st", st_floats * sizeof(float), CL_MEM_READ_ONLY, "fused coarse operators");
    for (size_t l = top; l < L; ++l)
      m_q.enqueueCopyBuffer(m_levels[l].st, m_fst, 0, size_t(meta[4 * (l - top) + 2]) * sizeof(float),
                            5 * size_t(ghosted(l)) * sizeof(float));
    // The coarse right-hand sides (ghosts never read, zeroed all the same).
    m_frs = m_ws.take("mg fused rs", lm_floats * sizeof(float), CL_MEM_READ_WRITE, "fused coarse right-hand sides");
    m_d.fill(m_frs, 0.0f, 0, lm_floats);
    m_fmeta = m_ws.take("mg fused meta", meta.size() * sizeof(cl_int), CL_MEM_READ_ONLY, "fused coarse level table");
    m_q.enqueueWriteBuffer(m_fmeta, CL_TRUE, 0, meta.size() * sizeof(cl_int), meta.data());
    m_fused_lm = lm_floats;
    m_fused_group = std::min<size_t>(m_d.info().launch == "wide" ? kFusedGroupWide : kFusedGroupRows, std::max<size_t>(1, m_fk.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(dev)));
    m_fused_top = top;
    m_stats.fused_level = int(top);
    track();
  }

  // Levels l >= m_fused_top: the whole cycle(l) in one work-group.
  void fused_cycle(size_t l, int gamma) {
    Level& T = m_levels[l];
    const int first = int(l - m_fused_top), last = int(m_levels.size() - 1 - m_fused_top);
    set_args(m_fk, T.e, T.r, m_fst, m_pinv, m_fmeta, first, last, m_o.pre_smooth, m_o.post_smooth, gamma,
             cl::Local(m_fused_lm * sizeof(float)), int(m_fused_lm), m_frs);
    const bool prof = profiling();
    const double t = prof ? now_ms() : 0;
    m_q.enqueueNDRangeKernel(m_fk, cl::NullRange, cl::NDRange(m_fused_group), cl::NDRange(m_fused_group));
    if (prof) record(m_fk, t, double(m_levels[m_fused_top].W) * m_levels[m_fused_top].H, 1);
  }

  /// sqrt(sum of squared level-0 residuals); `cold` measures the trivial guess instead of u.
  /// For u, also sets m_floor: the residual norm that float32 rounding of u alone would leave.
  double norm(bool cold) {
    cl::Kernel& k = cold ? m_rhs0 : m_norm0;
    set_args(k, m_p.u, m_p.g, m_p.width, m_p.height, m_wx, m_wy, m_rows);
    run(k, m_p.height, double(m_p.width) * m_p.height);
    const size_t H = size_t(m_p.height);
    m_q.enqueueReadBuffer(m_rows, CL_TRUE, 0, (cold ? 1 : 2) * H * sizeof(float), m_rows_host.data());
    double s = 0, f = 0;
    for (size_t y = 0; y < H; ++y) s += m_rows_host[y];
    if (!cold) {
      for (size_t y = 0; y < H; ++y) f += m_rows_host[H + y];
      m_floor = std::sqrt(f);
    }
    return std::sqrt(s);
  }

  // ---- smoothing, transfer, cycles ----
  // `reverse` runs the colours in reverse order (a symmetric V-cycle, e.g. for a CG preconditioner).
  void smooth0(int sweeps, bool reverse) {
    for (int s = 0; s < sweeps; ++s) {
      if (m_o.smoother == Smoother::Rbgs) {
        for (int c = 0; c < 2; ++c) {
          set_args(m_rb0, m_p.u, m_p.g, m_p.width, m_p.height, m_wx, m_wy, reverse ? 1 - c : c);
          run(m_rb0, m_p.height, double(m_p.width) * m_p.height / 2, (size_t(m_p.width) + 1) / 2);
        }
      } else {
        Level& L = m_levels[0];
        set_args(m_jac0, L.tmp, m_p.u, m_p.g, m_p.width, m_p.height, m_wx, m_wy, float(m_o.jacobi_omega));
        run(m_jac0, m_p.height, 0, m_p.width);
        std::swap(L.tmp, m_p.u);
      }
    }
  }

  void smooth(size_t l, int sweeps, bool reverse = false) {
    if (l == 0) return smooth0(sweeps, reverse);
    Level& L = m_levels[l];
    for (int s = 0; s < sweeps; ++s) {
      if (m_o.smoother == Smoother::Rbgs) {
        // Four colours on large levels; zebra rows (half the launches) where launches dominate.
        const int colours = int64_t(L.W) * L.H >= kFourColourCells ? 4 : 2;
        for (int cc = 0; cc < colours; ++cc) {
          const int c = reverse ? colours - 1 - cc : cc;
          const int px = colours == 4 ? (c & 1) : 0, py = colours == 4 ? (c >> 1) : c;
          set_args(m_z9, L.e, L.r, L.st, L.W, L.H, px, py, colours == 4 ? 2 : 1);
          run(m_z9, size_t((L.H - py + 1) / 2), double(L.W) * L.H / colours, colours == 4 ? size_t(L.W - px + 1) / 2 : 1);
        }
      } else {
        set_args(m_jac9, L.tmp, L.e, L.r, L.st, L.W, L.H, float(m_o.jacobi_omega));
        run(m_jac9, L.H, 0, L.W);
        std::swap(L.tmp, L.e);
      }
    }
  }

  void restrict_to(size_t l) {  // residual of level l -> rhs of level l+1, e_{l+1} = 0
    Level& F = m_levels[l];
    Level& C = m_levels[l + 1];
    if (l == 0) {
      set_args(m_rr0, m_p.u, m_p.g, m_p.width, m_p.height, m_wx, m_wy, C.r, C.e, C.W);
      run(m_rr0, C.H, double(C.W) * C.H * 4, C.W);
    } else {
      set_args(m_rr9, F.e, F.r, F.st, F.W, F.H, C.r, C.e, C.W);
      run(m_rr9, C.H, double(C.W) * C.H * 4, C.W);
    }
  }

  void prolong_from(size_t l) {  // level l += P e_{l+1}
    Level& C = m_levels[l + 1];
    if (l == 0) {
      set_args(m_pc0, m_p.u, m_p.g, m_p.width, m_p.height, C.e, C.W);
      run(m_pc0, m_p.height, double(m_p.width) * m_p.height, m_p.width);
    } else {
      Level& F = m_levels[l];
      set_args(m_pc9, F.e, F.W, F.H, C.e, C.W);
      run(m_pc9, F.H, double(F.W) * F.H, F.W);
    }
  }

  void coarse_solve() {
    Level& C = m_levels.back();
    const int n = C.W * C.H;
    set_args(m_cs, C.e, C.r, m_pinv, C.W, C.H);
    run(m_cs, size_t(n));
  }

  void cycle(size_t l, int gamma) {
    if (l >= m_fused_top) return fused_cycle(l, gamma);
    if (l + 1 == m_levels.size()) return coarse_solve();
    smooth(l, m_o.pre_smooth);
    restrict_to(l);
    cycle(l + 1, gamma);
    if (gamma > 1 && l + 2 < m_levels.size()) cycle(l + 1, gamma);
    prolong_from(l);
    // Same colour order as pre-smoothing: the reversed order (a symmetric V-cycle) needed 4 cycles
    // instead of 3 on the edit benchmark's thin hard curves.
    smooth(l, m_o.post_smooth);
  }

  void fmg_start() {
    // Restrict the initial residual down the hierarchy (coarse corrections start at 0), solve
    // the coarsest exactly, then interpolate up with kFmgCyclesPerLevel V-cycles per level.
    for (size_t l = 0; l + 1 < m_levels.size(); ++l) restrict_to(l);
    coarse_solve();
    for (size_t l = m_levels.size() - 1; l-- > 0;) {
      prolong_from(l);
      if (l > 0)
        for (int k = 0; k < kFmgCyclesPerLevel; ++k) cycle(l, 1);
    }
  }

  SolveStats run_cycles() {
    const double b = norm(true);
    m_stats.rhs_norm = b;
    auto rel = [&](double r) { return b > 0 ? r / b : 0.0; };
    // A cold start (free cells at the reference level) is the trivial guess itself: ratio 1.
    double r = m_o.initial ? rel(norm(false)) : (b > 0 ? 1.0 : 0.0);
    m_stats.residuals.push_back(r);
    if (r <= m_o.tolerance) {
      m_stats.converged = true;
      return m_stats;
    }
    const int gamma = m_o.cycle == Cycle::W ? 2 : 1;
    int slow = 0;
    for (int c = 0; c < m_o.max_cycles; ++c) {
      if (c == 0 && m_o.cycle == Cycle::Fmg) fmg_start();
      cycle(0, gamma);
      const double rn = rel(norm(false));
      m_stats.cycles = c + 1;
      m_stats.residuals.push_back(rn);
      if (profiling()) std::fprintf(stderr, "cycle %d: relative residual %.3e, %.2f x the float32 floor\n", c + 1, rn, rn * b / m_floor);
      report_progress(m_o.progress, "reconstruct", std::clamp(std::log(rn) / std::log(m_o.tolerance), 0.0, 1.0),
                      fmt::format("cycle {} residual {:.2e}", c + 1, rn));
      if (rn <= m_o.tolerance) {
        m_stats.converged = true;
        break;
      }
      // float32 floor: the residual is within kFloorFactor of what rounding u to float32 alone
      // leaves (the estimate of residual_norm0), or it stops shrinking.
      if (b > 0 && rn * b <= kFloorFactor * m_floor) {
        m_stats.stagnated = true;
        break;
      }
      slow = rn > 0.6 * r ? slow + 1 : 0;
      r = rn;
      if (slow >= 2) {
        m_stats.stagnated = true;
        break;
      }
    }
    return m_stats;
  }

  // ---- the published cascade ----
  SolveStats cascade() {
    const auto dims = multigrid_levels(m_p.width, m_p.height);
    const size_t L = dims.size();
    std::vector<Level> lv(L);
    for (size_t l = 0; l < L; ++l) {
      lv[l].W = dims[l].first;
      lv[l].H = dims[l].second;
      const size_t n = size_t(lv[l].W) * lv[l].H * sizeof(float);
      lv[l].tmp = m_d.buffer(n, CL_MEM_READ_WRITE, "cascade Jacobi buffer");
      if (l == 0) continue;
      lv[l].e = m_d.buffer(n, CL_MEM_READ_WRITE, "cascade solution");
      lv[l].r = m_d.buffer(n, CL_MEM_READ_WRITE, "cascade right-hand side");
    }
    track();
    m_stats.levels = int(L);
    lv[0].e = m_p.u;
    lv[0].r = m_p.g;
    cl::Kernel fuse = m_d.kernel("multigrid", "fuse_restrict");
    cl::Kernel pa = m_d.kernel("multigrid", "prolong_assign");
    for (size_t l = 0; l + 1 < L; ++l) {
      set_args(fuse, lv[l].r, lv[l].e, lv[l].W, lv[l].H, lv[l + 1].r, lv[l + 1].e, lv[l + 1].W, lv[l + 1].H);
      run(fuse, lv[l + 1].H, 0, lv[l + 1].W);
    }
    if (m_p.singular) {
      // Without any hard cell the border-renormalised coarse right-hand sides are not exactly
      // zero-mean, and Jacobi on a singular Neumann problem then drifts: project each level.
      cl::Kernel rs = m_d.kernel("multigrid", "row_sums");
      cl::Kernel sh = m_d.kernel("multigrid", "shift_free");
      for (size_t l = 1; l < L; ++l) {
        std::vector<float> rows(size_t(lv[l].H));
        cl::Buffer rb = m_d.buffer(rows.size() * sizeof(float), CL_MEM_READ_WRITE, "cascade row sums");
        set_args(rs, lv[l].r, lv[l].W, lv[l].H, rb);
        run(rs, lv[l].H);
        m_q.enqueueReadBuffer(rb, CL_TRUE, 0, rows.size() * sizeof(float), rows.data());
        double sum = 0;
        for (float v : rows) sum += v;
        set_args(sh, lv[l].r, lv[l].W, lv[l].H, float(sum / (double(lv[l].W) * lv[l].H)));
        run(sh, lv[l].H);
      }
    }
    const double b = norm(true);
    m_stats.residuals.push_back(b > 0 ? norm(false) / b : 0.0);
    for (size_t l = L; l-- > 0;) {
      if (l + 1 < L) {
        set_args(pa, lv[l].e, lv[l].r, lv[l].W, lv[l].H, lv[l + 1].e, lv[l + 1].W);
        run(pa, lv[l].H, 0, lv[l].W);
      }
      const double scale = std::ldexp(1.0, int(l));
      const float wx = float(1.0 / (p2(m_p.cell_x * scale))), wy = float(1.0 / p2(m_p.cell_y * scale));
      const int sweeps = 50 + 10 * int(L - 1 - l);
      for (int s = 0; s < sweeps; ++s) {
        set_args(m_jac0, lv[l].tmp, lv[l].e, lv[l].r, lv[l].W, lv[l].H, wx, wy, 1.0f);
        run(m_jac0, lv[l].H, 0, lv[l].W);
        std::swap(lv[l].tmp, lv[l].e);
      }
    }
    m_p.u = lv[0].e;
    m_stats.cycles = 1;
    const double rn = b > 0 ? norm(false) / b : 0.0;
    m_stats.residuals.push_back(rn);
    m_stats.converged = rn <= m_o.tolerance;
    return m_stats;
  }

  SolveStats& stats() { return m_stats; }
  /// One fine-level cycle of the configured kind (refine.cpp's correction solve).
  void fine_cycle() { cycle(0, m_o.cycle == Cycle::W ? 2 : 1); }

 private:
  static double p2(double v) { return v * v; }
  // `n` rows; `w` > 0: a cell kernel (kernels/launch.clh) over w columns, launched in the device's
  // shape; else one work-item per row.
  void run(cl::Kernel& k, size_t n, double items = 0, size_t w = 0) {
    if (n == 0) return;
    const bool prof = profiling();
    const double t = prof ? now_ms() : 0;
    if (w > 0)
      launch_grid(m_d, k, w, n);
    else
      launch_rows(m_d, k, n);
    if (prof) record(k, t, items, n);
  }

  void record(cl::Kernel& k, double t, double items, size_t n) {
    m_q.finish();
    std::string name = k.getInfo<CL_KERNEL_FUNCTION_NAME>();
    name = name.c_str();
    auto& e = profile()[std::getenv("TERRACL_MG_PROFILE")[0] == '2' ? fmt::format("{}@{}", name, n) : name];
    e.ms += now_ms() - t;
    e.calls++;
    e.items += items > 0 ? items : double(n);
  }

  Device& m_d;
  cl::CommandQueue& m_q;
  Problem& m_p;
  const SolverOptions& m_o;
  const AllocationScope& m_scope;
  WorkspaceBuffers m_ws;
  float m_wx = 1, m_wy = 1;
  std::vector<Level> m_levels;
  cl::Kernel m_rb0, m_jac0, m_rr0, m_pc0, m_norm0, m_rhs0, m_z9, m_jac9, m_rr9, m_pc9, m_cs;
  cl::Buffer m_rows, m_pinv;
  // Fused coarse cycle (build_fused): levels >= m_fused_top (none when past the last level).
  cl::Kernel m_fk;
  cl::Buffer m_fst, m_fmeta, m_frs;
  size_t m_fused_top = SIZE_MAX, m_fused_lm = 0, m_fused_group = 1;
  std::vector<float> m_rows_host, m_pinv_host;
  SolveStats m_stats;
  double m_floor = 0;
};

}  // namespace

SolveStats solve(Device& d, Problem& p, const SolverOptions& o, const AllocationScope& scope) {
  const double t0 = now_ms();
  Solver s(d, p, o, scope);
  s.track();
  if (o.cycle == Cycle::Cascade) return s.cascade();
  s.build();
  if (p.phases) d.queue().finish();
  const double t_built = now_ms();
  s.stats().setup_ms = t_built - t0;
  SolveStats st = s.run_cycles();
  if (p.phases) d.queue().finish();
  const double t_cycled = now_ms();
  st.cycles_ms = t_cycled - t_built;
  refine(d, p, o, st, scope, s.buffers(), [&] { s.fine_cycle(); });
  // Refined, the answer is the double solution: the tolerance is met when its residual meets it.
  if (st.refine_cycles > 0 && !st.refine_residuals.empty() && st.refine_residuals.back() <= o.tolerance) {
    st.converged = true;
    st.stagnated = false;
  }
  if (p.phases) d.queue().finish();
  st.refine_ms = now_ms() - t_cycled;
  if (profiling()) {
    print_profile();
    if (st.fused_level >= 0) std::fprintf(stderr, "fused coarse cycle from level %d of %d\n", st.fused_level, st.levels);
  }
  return st;
}

}  // namespace terracl::mg
