// SPDX-License-Identifier: Apache-2.0
// Mixed-precision iterative refinement (docs/reconstruct.md). The float32
// multigrid stops where float rounding of u hides the residual; on problems with large free
// regions the remaining smooth error is then far above the residual (2.6e-4 of the range at a
// 1.5e-6 relative residual on a sparse-constraint canyon). Here the solution lives in double, its
// residual is computed in double and each float multigrid cycle only solves for the correction,
// whose own rounding error is a float's share of a small number.
#include "reconstruct/refine.hpp"
#include "cl/row_launch.hpp"
#include "cl/workspace.hpp"

#include <terracl/error.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

namespace terracl::mg {
namespace {

// A correction that shrinks by less than this counts as slow; two in a row stop (the corrections
// then sit at the rounding floor of the float correction solve). Not lower: on sparse-constraint
// problems the V-cycle itself reduces the error by only 0.45-0.65 per cycle (measured), which
// must not read as stagnation.
constexpr double kSlowRatio = 0.9;
constexpr double kMinContraction = 0.3;

bool has_fp64(Device& d) {
  return d.device().getInfo<CL_DEVICE_EXTENSIONS>().find("cl_khr_fp64") != std::string::npos;
}

struct Correction {
  double max_abs = 0, range = 0;  // largest |correction| of a cycle, range of the solution after it
};

// The two paths share the loop: `residual` writes the correction problem (p.g, p.u = 0) and
// returns the double residual norm, `accumulate` adds the solved correction to the double
// solution, `finish` puts float(U) back into p.u.
struct Path {
  std::function<double()> residual;
  std::function<Correction()> accumulate;
  std::function<void()> finish;
};

// Step length alpha = (d, r) / (d, A d) along direction d (kernels/refine.cl); 1 where the sums say
// nothing (a zero or constant direction).
double step_length(double dr, double dad) {
  const double a = dad > 0 ? dr / dad : 0.0;
  return a > 0 && std::isfinite(a) ? a : 1.0;
}

// Stop rule: the error left, estimated from the last correction k_n and the contraction
// q = k_n / k_{n-1} of the last two (error ~ k_n q / (1 - q)), is at most o.refine_tolerance of the
// solution's range; after the first cycle (no q yet) only a correction that small itself stops.
// q is taken as at least kMinContraction: CG's contraction varies from cycle to cycle (the 257^2
// canyon of tests/test_refine.cpp: q = 0.023 after cycle 2 with 3.2e-7 of the range left, 10x the
// estimate). The old rule (stop once k_n <= tolerance) needs one more cycle where q is small.
void loop(const Path& path, const SolverOptions& o, SolveStats& st, const std::function<void()>& fine_cycle) {
  const double b = st.rhs_norm;
  auto rel = [&](double r) { return b > 0 ? r / b : 0.0; };
  st.refine_residuals.push_back(rel(path.residual()));
  double last = 0;
  int slow = 0;
  for (int c = 0; c < o.max_cycles; ++c) {
    fine_cycle();
    const Correction k = path.accumulate();
    st.refine_residuals.push_back(rel(path.residual()));
    st.refine_cycles = c + 1;
    const double bound = o.refine_tolerance * k.range;
    if (std::getenv("TERRACL_MG_PROFILE"))
      std::fprintf(stderr, "refinement cycle %d: correction %.3e of the range\n", c + 1, k.max_abs / k.range);
    if (k.max_abs <= bound) break;
    if (c > 0 && last > 0) {
      const double q = std::max(k.max_abs / last, kMinContraction);
      if (q < kSlowRatio && k.max_abs * q / (1 - q) <= bound) break;
    }
    slow = c > 0 && k.max_abs > kSlowRatio * last ? slow + 1 : 0;
    last = k.max_abs;
    if (slow >= 2) break;
  }
  path.finish();
}

}  // namespace

void refine(Device& d, Problem& p, const SolverOptions& o, SolveStats& st, const AllocationScope& scope, WorkspaceBuffers& ws,
            const std::function<void()>& fine_cycle) {
  if (o.refine == Refinement::Off) return;
  const bool fp64 = has_fp64(d);
  if (o.refine == Refinement::Device && !fp64)
    fail("reconstruct", "refinement on the device needs double precision (cl_khr_fp64), which {} lacks; use "
         "--refine auto or host", d.info().name);
  const bool on_device = o.refine == Refinement::Device || (o.refine == Refinement::Auto && fp64);
  if (!(st.rhs_norm > 0)) return;  // nothing to solve (the float solve was exact from the start)
  const int W = p.width, H = p.height;
  const size_t N = size_t(W) * H;
  const double wx = 1.0 / (p.cell_x * p.cell_x), wy = 1.0 / (p.cell_y * p.cell_y);
  cl::CommandQueue& q = d.queue();
  // The vectors come from the workspace (cached between solves of one grid size: on a GPU the
  // creation and first touch of ~32 bytes per cell cost more than the refinement's kernels);
  // the reused ones were allocated before the solve and are added back.
  auto track = [&] { st.peak_bytes = std::max<uint64_t>(st.peak_bytes, scope.live() + ws.reused()); };
  // The correction problem gets its own right-hand side buffer (same NaN pattern, so the coarse
  // operators already built stay valid); the original g comes back at the end.
  cl::Buffer g0 = p.g;
  p.g = ws.take("refine g", N * sizeof(float), CL_MEM_READ_WRITE, "refinement right-hand side");
  Path path;
  if (on_device) {
    st.refinement = "device-fp64";
    cl::Buffer U = ws.take("refine U", N * sizeof(double), CL_MEM_READ_WRITE, "refinement solution (double)");
    cl::Buffer rows = ws.take("refine rows", 5 * size_t(H) * sizeof(double), CL_MEM_READ_WRITE, "refinement per-row figures");
    cl::Buffer R = ws.take("refine R", N * sizeof(double), CL_MEM_READ_WRITE, "refinement residual (double)");
    // Flexible CG (kernels/refine.cl): the previous and the current search direction.
    cl::Buffer dprev = ws.take("refine d0", N * sizeof(float), CL_MEM_READ_WRITE, "refinement search direction");
    cl::Buffer dcur = ws.take("refine d1", N * sizeof(float), CL_MEM_READ_WRITE, "refinement search direction");
    cl::Buffer qdir = ws.take("refine q", N * sizeof(float), CL_MEM_READ_WRITE, "refinement A times direction");
    d.fill(dprev, 0.0f, 0, N);
    d.fill(qdir, 0.0f, 0, N);
    track();
    cl::Kernel widen = d.kernel("refine", "refine_widen"), res = d.kernel("refine", "refine_residual"),
               acc = d.kernel("refine", "refine_accumulate"), narrow = d.kernel("refine", "refine_narrow"),
               fsums = d.kernel("refine", "refine_fcg_sums");
    double next_norm = -1;  // the residual norm refine_accumulate left (its recurrence), -1: none
    std::vector<double> rows_host(5 * size_t(H));
    auto row_sum = [&](size_t stride, size_t k) {
      double s = 0;
      for (size_t y = 0; y < size_t(H); ++y) s += rows_host[stride * y + k];
      return s;
    };
    set_args(widen, U, p.u, W, H);
    launch_rows(d, widen, size_t(H));
    path.residual = [&] {
      if (next_norm >= 0) return std::exchange(next_norm, -1.0);
      set_args(res, U, g0, W, H, wx, wy, p.g, p.u, rows, R);
      launch_rows(d, res, size_t(H));
      q.enqueueReadBuffer(rows, CL_TRUE, 0, size_t(H) * sizeof(double), rows_host.data());
      return std::sqrt(row_sum(1, 0));
    };
    path.accumulate = [&] {
      set_args(fsums, p.u, dprev, qdir, p.g, W, H, wx, wy, dcur, rows);
      launch_rows(d, fsums, size_t(H));
      q.enqueueReadBuffer(rows, CL_TRUE, 0, 5 * size_t(H) * sizeof(double), rows_host.data());
      const double cr = row_sum(5, 0), dr = row_sum(5, 1), cac = row_sum(5, 2), cq = row_sum(5, 3),
                   dq = row_sum(5, 4);
      double beta = dq > 0 ? cq / dq : 0.0;
      if (!std::isfinite(beta)) beta = 0;
      double alpha = step_length(cr - beta * dr, cac - 2 * beta * cq + beta * beta * dq);
      if (beta != 0 && !(cac - 2 * beta * cq + beta * beta * dq > 0)) {  // lost to cancellation: restart
        beta = 0;
        alpha = step_length(cr, cac);
      }
      set_args(acc, U, p.u, dprev, beta, dcur, qdir, g0, W, H, alpha, rows, R, p.g);
      launch_rows(d, acc, size_t(H));
      std::swap(dprev, dcur);    // dcur held A c, now d
      d.fill(p.u, 0.0f, 0, N);  // the next correction's zero guess
      q.enqueueReadBuffer(rows, CL_TRUE, 0, 4 * size_t(H) * sizeof(double), rows_host.data());
      Correction k;
      double lo = rows_host[1], hi = rows_host[2];
      for (size_t y = 0; y < size_t(H); ++y) {
        k.max_abs = std::max(k.max_abs, rows_host[4 * y]);
        lo = std::min(lo, rows_host[4 * y + 1]);
        hi = std::max(hi, rows_host[4 * y + 2]);
      }
      k.range = hi - lo;
      next_norm = std::sqrt(row_sum(4, 3));
      return k;
    };
    path.finish = [&] {
      set_args(narrow, p.u, U, W, H);
      launch_rows(d, narrow, size_t(H));
    };
    loop(path, o, st, fine_cycle);
  } else {
    // Last resort (no fp64 on the device): the same in double on the host, two transfers a cycle.
    st.refinement = "host-double";
    std::vector<float> g(N), u(N);
    std::vector<double> U(N);
    q.enqueueReadBuffer(g0, CL_FALSE, 0, N * sizeof(float), g.data());
    q.enqueueReadBuffer(p.u, CL_TRUE, 0, N * sizeof(float), u.data());
    for (size_t i = 0; i < N; ++i) U[i] = u[i];
    std::vector<float> gc(N);
    track();
    path.residual = [&] {
      double s = 0;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t i = size_t(y) * W + x;
          if (std::isnan(g[i])) {
            gc[i] = g[i];
            continue;
          }
          const double c = U[i];
          double r = double(g[i]);
          if (x > 0) r += wx * (U[i - 1] - c);
          if (x + 1 < W) r += wx * (U[i + 1] - c);
          if (y > 0) r += wy * (U[i - W] - c);
          if (y + 1 < H) r += wy * (U[i + W] - c);
          gc[i] = float(r);
          s += r * r;
        }
      q.enqueueWriteBuffer(p.g, CL_FALSE, 0, N * sizeof(float), gc.data());
      d.fill(p.u, 0.0f, 0, N);
      q.finish();  // gc is rewritten by the next call
      return std::sqrt(s);
    };
    path.accumulate = [&] {
      q.enqueueReadBuffer(p.u, CL_TRUE, 0, N * sizeof(float), u.data());
      // The step length of refine_fcg_sums without a previous direction (gc: the residual solved).
      double cr = 0, cac = 0;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t i = size_t(y) * W + x;
          if (std::isnan(gc[i])) continue;
          const double c = u[i];
          double ac = 0;
          if (x > 0) ac += wx * (c - double(u[i - 1]));
          if (x + 1 < W) ac += wx * (c - double(u[i + 1]));
          if (y > 0) ac += wy * (c - double(u[i - W]));
          if (y + 1 < H) ac += wy * (c - double(u[i + W]));
          cr += c * double(gc[i]);
          cac += c * ac;
        }
      const double alpha = step_length(cr, cac);
      Correction k;
      double lo = U[0], hi = U[0];
      for (size_t i = 0; i < N; ++i) {
        if (!std::isnan(g[i])) {
          const double c = alpha * double(u[i]);
          U[i] += c;
          k.max_abs = std::max(k.max_abs, std::fabs(c));
        }
        lo = std::min(lo, U[i]);
        hi = std::max(hi, U[i]);
      }
      k.range = hi - lo;
      return k;
    };
    path.finish = [&] {
      for (size_t i = 0; i < N; ++i) u[i] = float(U[i]);
      q.enqueueWriteBuffer(p.u, CL_TRUE, 0, N * sizeof(float), u.data());
    };
    loop(path, o, st, fine_cycle);
  }
  p.g = g0;
}

}  // namespace terracl::mg
