// SPDX-License-Identifier: Apache-2.0
// hypre back end of the reconstruction: the same discrete problem as the device multigrid (5-point
// Laplacian with natural Neumann border, hard cells as Dirichlet nodes) assembled on hypre's Struct
// interface and solved by PFMG-preconditioned CG in double. Under mpirun every rank owns a band of
// rows (one hypre box); the bands are gathered so that every rank holds the result.
#include "reconstruct/hypre_solve.hpp"

#include <terracl/error.hpp>
#include <terracl/hypre.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <limits>

#ifdef TERRACL_HAVE_HYPRE
#include <HYPRE_struct_ls.h>
#include <HYPRE_utilities.h>
#include <mpi.h>
#endif

namespace terracl {

hypre::BandReader hypre::whole_problem(int W, const RowDivergence& div, const std::vector<uint32_t>& hard_index,
                                       const std::vector<float>& hard_value, const Heightfield* initial) {
  return [=, &hard_index, &hard_value](int y0, int y1, int h0, int h1) {
    Band b;
    b.div = div;
    const auto lo = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(h0) * W));
    const auto hi = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(h1) * W));
    b.hard_index.assign(lo, hi);
    b.hard_value.assign(hard_value.begin() + (lo - hard_index.begin()), hard_value.begin() + (hi - hard_index.begin()));
    if (initial)
      b.initial.assign(initial->z.begin() + ptrdiff_t(size_t(y0) * W), initial->z.begin() + ptrdiff_t(size_t(y1) * W));
    return b;
  };
}

#ifndef TERRACL_HAVE_HYPRE

bool hypre_available() { return false; }
bool hypre_is_root_rank() { return true; }

namespace hypre {
ReconstructResult solve(int, int, const Georef&, const Metadata&, const BandReader&, double, const SolverOptions&,
                        bool) {
  fail("reconstruct", "--solver hypre: this build has no hypre (configure with -DTERRACL_MPI=ON and Debian's "
                      "libhypre-dev and libopenmpi-dev); use --solver multigrid");
}
}  // namespace hypre

#else

bool hypre_available() { return true; }

bool hypre_is_root_rank() {
  int init = 0, fin = 0;
  MPI_Initialized(&init);
  MPI_Finalized(&fin);
  if (!init || fin) return true;
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank == 0;
}

namespace hypre {
namespace {

double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

void finalize_at_exit() {
  int fin = 0;
  MPI_Finalized(&fin);
  if (fin) return;
  HYPRE_Finalize();
  MPI_Finalize();
}

// MPI may already be up (the tile distribution of `terracl run` under mpirun initialises it);
// otherwise the first hypre solve starts it (a singleton without mpirun) and exit finalises it.
void ensure_started() {
  static bool hypre_started = false;
  int init = 0;
  MPI_Initialized(&init);
  if (!init) {
    int fin = 0;
    MPI_Finalized(&fin);
    if (fin) fail("reconstruct", "hypre: MPI was already finalised in this process");
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
      fail("reconstruct", "hypre: MPI_Init failed");
    std::atexit(finalize_at_exit);
  }
  if (!hypre_started) {
    HYPRE_Init();
    hypre_started = true;
  }
}

void check(HYPRE_Int err, const char* what) {
  if (!err) return;
  char msg[256] = {0};
  HYPRE_DescribeError(err, msg);
  HYPRE_ClearAllErrors();
  fail("reconstruct", "hypre: {} failed: {}", what, msg);
}

// hypre objects of one solve, destroyed on every exit path.
struct Objects {
  HYPRE_StructGrid grid = nullptr;
  HYPRE_StructStencil stencil = nullptr;
  HYPRE_StructMatrix A = nullptr;
  HYPRE_StructVector b = nullptr, x = nullptr;
  HYPRE_StructSolver pcg = nullptr, pfmg = nullptr;
  ~Objects() { release(); }
  void release() {
    if (pfmg) HYPRE_StructPFMGDestroy(pfmg);
    if (pcg) HYPRE_StructPCGDestroy(pcg);
    if (x) HYPRE_StructVectorDestroy(x);
    if (b) HYPRE_StructVectorDestroy(b);
    if (A) HYPRE_StructMatrixDestroy(A);
    if (stencil) HYPRE_StructStencilDestroy(stencil);
    if (grid) HYPRE_StructGridDestroy(grid);
    pfmg = pcg = nullptr;
    x = b = nullptr;
    A = nullptr;
    stencil = nullptr;
    grid = nullptr;
  }
};

}  // namespace

ReconstructResult solve(int W, int H, const Georef& georef, const Metadata& meta, const BandReader& read_band,
                        double target, const SolverOptions& o, bool gather_to_all) {
  const size_t N = size_t(W) * size_t(H);
  if (N > size_t(INT_MAX)) fail("reconstruct", "hypre: grid {}x{} has more than 2^31 cells (MPI counts are int)", W, H);
  ensure_started();  // not timed: MPI's start-up happens once per process
  const double t0 = now_ms();
  const MPI_Comm comm = MPI_COMM_WORLD;
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);
  if (ranks > H) fail("reconstruct", "hypre: {} MPI ranks for {} rows: each rank needs at least one row", ranks, H);

  // This rank's band of rows [y0, y1) and the rows either side that its stencils reach.
  const int y0 = int(int64_t(H) * rank / ranks), y1 = int(int64_t(H) * (rank + 1) / ranks);
  const int rows = y1 - y0;
  const int h0 = std::max(0, y0 - 1), h1 = std::min(H, y1 + 1);
  const size_t band = size_t(rows) * W;
  Band in = read_band(y0, y1, h0, h1);
  const std::vector<uint32_t>& hard_index = in.hard_index;
  const std::vector<float>& hard_value = in.hard_value;
  if (!in.initial.empty() && in.initial.size() != band)
    fail("reconstruct", "hypre: the start heightfield's band holds {} cells, not {}", in.initial.size(), band);

  // Hard cells on this rank's own rows, counted once over the ranks; the sums run in row order
  // (with one rank the same sums as a whole-grid solve).
  const auto own0 = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(y0) * W));
  const auto own1 = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(y1) * W));
  double sums[3] = {0, double(own1 - own0), 0};  // hard sum, hard count, start-field sum
  for (auto it = own0; it != own1; ++it) sums[0] += hard_value[it - hard_index.begin()];
  const bool start_mean = !std::isfinite(target) && !in.initial.empty();
  if (start_mean)
    for (float v : in.initial) sums[2] += v;
  double totals[3] = {sums[0], sums[1], sums[2]};
  if (ranks > 1) MPI_Allreduce(sums, totals, 3, MPI_DOUBLE, MPI_SUM, comm);
  if (!std::isfinite(target)) target = start_mean ? totals[2] / double(N) : 0.0;

  const bool singular = totals[1] == 0;
  // The unknown is the deviation from m, as on the device (here for symmetry of the two paths;
  // double would not need it).
  const double m = singular ? target : totals[0] / totals[1];

  // Hard deviations u0 = value - m on rows [h0, h1): one flag byte per cell (a dense double array
  // would cost 8 bytes a cell), the values from this band's slice of the sorted hard list. Without
  // hard cells the pure-Neumann problem is singular: cell (0, 0) is pinned to 0 and the mean set
  // afterwards (f is projected onto zero mean first, so that equation holds anyway).
  const auto lo = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(h0) * W));
  const auto hi = std::lower_bound(hard_index.begin(), hard_index.end(), uint32_t(size_t(h1) * W));
  std::vector<uint8_t> hard_flag(size_t(h1 - h0) * W, 0);
  for (auto it = lo; it != hi; ++it) hard_flag[*it - size_t(h0) * W] = 1;
  const bool pinned = singular && h0 == 0;
  if (pinned) hard_flag[0] = 1;
  auto is_hard = [&](int x, int y) { return hard_flag[size_t(y - h0) * W + x] != 0; };
  // The resolved value of a hard cell (NaN for the pinned cell, which has none).
  auto hard_v = [&](int x, int y) -> float {
    const uint32_t i = uint32_t(size_t(y) * W + x);
    if (pinned && i == 0) return std::numeric_limits<float>::quiet_NaN();
    return hard_value[std::lower_bound(lo, hi, i) - hard_index.begin()];
  };
  auto hard_u = [&](int x, int y) -> double {
    const float v = hard_v(x, y);
    return std::isnan(v) ? 0.0 : double(v) - m;
  };

  // The divergence of this band, scaled by cx*cy so that the weights are cy/cx and cx/cy (the
  // relative residual is invariant under the scale).
  const double cx = georef.cell_x, cy = georef.cell_y, s = cx * cy, wx = cy / cx, wy = cx / cy;
  std::vector<double> f(band);
  for (int y = y0; y < y1; ++y) in.div(y, f.data() + size_t(y - y0) * W);
  in.div = nullptr;  // drops the band's input (a gradient band is 8 bytes a cell)
  if (singular) {
    double local = 0, total = 0;
    for (double v : f) local += v;
    MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, comm);
    const double mean = total / double(N);
    for (double& v : f) v -= mean;
  }

  Objects ob;
  HYPRE_Int lower[2] = {0, y0}, upper[2] = {W - 1, y1 - 1};
  check(HYPRE_StructGridCreate(comm, 2, &ob.grid), "StructGridCreate");
  check(HYPRE_StructGridSetExtents(ob.grid, lower, upper), "StructGridSetExtents");
  check(HYPRE_StructGridAssemble(ob.grid), "StructGridAssemble");
  // Symmetric storage: centre, west and south; east and north follow from symmetry.
  HYPRE_Int offsets[3][2] = {{0, 0}, {-1, 0}, {0, -1}};
  check(HYPRE_StructStencilCreate(2, 3, &ob.stencil), "StructStencilCreate");
  for (HYPRE_Int e = 0; e < 3; ++e) check(HYPRE_StructStencilSetElement(ob.stencil, e, offsets[e]), "StencilSetElement");
  check(HYPRE_StructMatrixCreate(comm, ob.grid, ob.stencil, &ob.A), "StructMatrixCreate");
  check(HYPRE_StructMatrixSetSymmetric(ob.A, 1), "StructMatrixSetSymmetric");
  check(HYPRE_StructMatrixInitialize(ob.A), "StructMatrixInitialize");
  check(HYPRE_StructVectorCreate(comm, ob.grid, &ob.b), "StructVectorCreate");
  check(HYPRE_StructVectorCreate(comm, ob.grid, &ob.x), "StructVectorCreate");
  check(HYPRE_StructVectorInitialize(ob.b), "StructVectorInitialize");
  check(HYPRE_StructVectorInitialize(ob.x), "StructVectorInitialize");

  // A = -L on free cells with the couplings to hard cells and to outside the grid removed (the
  // right-hand side takes the hard values), identity (scaled like the free rows) on hard cells:
  // symmetric positive definite. The unknown is the correction x to u0 (hard values, 0 elsewhere),
  // so b is the residual of that trivial guess, the same b as the device solver's stopping rule,
  // and hard rows stay 0. Rows go in in chunks to bound the staging memory.
  const int chunk = std::max(1, int((1 << 22) / std::max(W, 1)));
  std::vector<double> av, bv, xv;
  HYPRE_Int entries[3] = {0, 1, 2};
  for (int c0 = y0; c0 < y1; c0 += chunk) {
    const int c1 = std::min(y1, c0 + chunk);
    const size_t n = size_t(c1 - c0) * W;
    av.assign(3 * n, 0.0);
    bv.assign(n, 0.0);
    xv.assign(n, 0.0);
    for (int y = c0; y < c1; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t k = size_t(y - c0) * W + x;
        double* a = &av[3 * k];
        if (is_hard(x, y)) {
          a[0] = 2 * (wx + wy);
          continue;
        }
        double diag = 0, rhs = -s * f[size_t(y - y0) * W + x];
        auto nb = [&](bool in, int nx, int ny, double w, double* entry) {
          if (!in) return;
          diag += w;
          if (is_hard(nx, ny)) rhs += w * hard_u(nx, ny);
          else if (entry) *entry = -w;
        };
        nb(x > 0, x - 1, y, wx, &a[1]);
        nb(x + 1 < W, x + 1, y, wx, nullptr);
        nb(y > 0, x, y - 1, wy, &a[2]);
        nb(y + 1 < H, x, y + 1, wy, nullptr);
        a[0] = diag;
        bv[k] = rhs;
        if (!in.initial.empty()) xv[k] = double(in.initial[size_t(y - y0) * W + x]) - m;
      }
    HYPRE_Int lo[2] = {0, c0}, up[2] = {W - 1, c1 - 1};
    check(HYPRE_StructMatrixSetBoxValues(ob.A, lo, up, 3, entries, av.data()), "StructMatrixSetBoxValues");
    check(HYPRE_StructVectorSetBoxValues(ob.b, lo, up, bv.data()), "StructVectorSetBoxValues");
    check(HYPRE_StructVectorSetBoxValues(ob.x, lo, up, xv.data()), "StructVectorSetBoxValues");
  }
  std::vector<double>().swap(av);
  std::vector<double>().swap(f);
  std::vector<float>().swap(in.initial);
  check(HYPRE_StructMatrixAssemble(ob.A), "StructMatrixAssemble");
  check(HYPRE_StructVectorAssemble(ob.b), "StructVectorAssemble");
  check(HYPRE_StructVectorAssemble(ob.x), "StructVectorAssemble");

  check(HYPRE_StructPCGCreate(comm, &ob.pcg), "StructPCGCreate");
  check(HYPRE_StructPCGSetTol(ob.pcg, o.tolerance), "StructPCGSetTol");
  check(HYPRE_StructPCGSetMaxIter(ob.pcg, o.max_cycles), "StructPCGSetMaxIter");
  check(HYPRE_StructPCGSetTwoNorm(ob.pcg, 1), "StructPCGSetTwoNorm");
  check(HYPRE_StructPCGSetRelChange(ob.pcg, 0), "StructPCGSetRelChange");
  // One symmetric PFMG V(1,1) cycle (red/black Gauss-Seidel, red-black down and black-red up) per
  // CG iteration: a symmetric preconditioner, as CG needs.
  check(HYPRE_StructPFMGCreate(comm, &ob.pfmg), "StructPFMGCreate");
  check(HYPRE_StructPFMGSetMaxIter(ob.pfmg, 1), "StructPFMGSetMaxIter");
  check(HYPRE_StructPFMGSetTol(ob.pfmg, 0.0), "StructPFMGSetTol");
  check(HYPRE_StructPFMGSetZeroGuess(ob.pfmg), "StructPFMGSetZeroGuess");
  check(HYPRE_StructPFMGSetRelaxType(ob.pfmg, 2), "StructPFMGSetRelaxType");
  check(HYPRE_StructPFMGSetNumPreRelax(ob.pfmg, 1), "StructPFMGSetNumPreRelax");
  check(HYPRE_StructPFMGSetNumPostRelax(ob.pfmg, 1), "StructPFMGSetNumPostRelax");
  check(HYPRE_StructPCGSetPrecond(ob.pcg, HYPRE_StructPFMGSolve, HYPRE_StructPFMGSetup, ob.pfmg), "StructPCGSetPrecond");
  check(HYPRE_StructPCGSetup(ob.pcg, ob.A, ob.b, ob.x), "StructPCGSetup");
  const double t_setup = now_ms();
  // A run that stops at the iteration limit returns HYPRE_ERROR_CONV: reported as not converged.
  const HYPRE_Int err = HYPRE_StructPCGSolve(ob.pcg, ob.A, ob.b, ob.x);
  if (err && !HYPRE_CheckError(err, HYPRE_ERROR_CONV)) check(err, "StructPCGSolve");
  HYPRE_ClearAllErrors();
  const double t_solved = now_ms();
  HYPRE_Int iters = 0;
  HYPRE_Real rel = 0;
  HYPRE_StructPCGGetNumIterations(ob.pcg, &iters);
  HYPRE_StructPCGGetFinalRelativeResidualNorm(ob.pcg, &rel);

  // h = m + u0 + x on this band, gathered to every rank in float.
  std::vector<float> mine(band);
  for (int c0 = y0; c0 < y1; c0 += chunk) {
    const int c1 = std::min(y1, c0 + chunk);
    xv.assign(size_t(c1 - c0) * W, 0.0);
    HYPRE_Int lo[2] = {0, c0}, up[2] = {W - 1, c1 - 1};
    check(HYPRE_StructVectorGetBoxValues(ob.x, lo, up, xv.data()), "StructVectorGetBoxValues");
    for (int y = c0; y < c1; ++y)
      for (int x = 0; x < W; ++x) {
        // Hard cells keep their values bit-exactly (the pinned cell of a singular problem is m).
        const float hv = is_hard(x, y) ? hard_v(x, y) : 0.0f;
        mine[size_t(y - y0) * W + x] =
            !is_hard(x, y) ? float(m + xv[size_t(y - c0) * W + x]) : std::isnan(hv) ? float(m) : hv;
      }
  }
  ob.release();  // hypre's matrix, vectors and hierarchy go before the whole field is gathered
  std::vector<double>().swap(xv);
  std::vector<uint8_t>().swap(hard_flag);
  std::vector<uint32_t>().swap(in.hard_index);
  std::vector<float>().swap(in.hard_value);

  ReconstructResult res;
  Heightfield& h = res.height;
  h.width = W;
  h.height = H;
  std::vector<int> counts(ranks), displs(ranks);
  for (int r = 0; r < ranks; ++r) {
    const int a = int(int64_t(H) * r / ranks), e = int(int64_t(H) * (r + 1) / ranks);
    counts[r] = (e - a) * W;
    displs[r] = a * W;
  }
  // The mean shift, the hard values and the finiteness check run on the whole field in one order
  // (rank 0's, or every rank's alike), so that any number of ranks gives the same bytes.
  const bool holds = gather_to_all || rank == 0;
  if (holds) h.z.resize(N);
  if (gather_to_all)
    MPI_Allgatherv(mine.data(), int(band), MPI_FLOAT, h.z.data(), counts.data(), displs.data(), MPI_FLOAT, comm);
  else
    MPI_Gatherv(mine.data(), int(band), MPI_FLOAT, holds ? h.z.data() : nullptr, counts.data(), displs.data(),
                MPI_FLOAT, 0, comm);
  std::vector<float>().swap(mine);

  h.georef = georef;
  h.georef.vertical_units = "m";
  h.metadata = meta;
  h.metadata.erase("terracl:gradient");
  int bad = -1;  // the first non-finite cell, told to every rank so that all fail alike
  if (holds) {
    if (singular) {
      double sum = 0;
      for (float v : h.z) sum += v;
      const double shift = target - sum / double(N);
      for (float& v : h.z) v = float(double(v) + shift);
    }
    for (size_t i = 0; i < N && bad < 0; ++i)
      if (!std::isfinite(h.z[i])) bad = int(i);
  }
  if (!gather_to_all) MPI_Bcast(&bad, 1, MPI_INT, 0, comm);
  if (bad >= 0)
    fail("reconstruct", "hypre produced a non-finite value at cell ({}, {}): values too large for float32", bad % W,
         bad / W);

  res.solver = "hypre";
  res.ranks = ranks;
  res.device = fmt::format("hypre PFMG-CG (host, double, {} MPI rank{}{})", ranks, ranks == 1 ? "" : "s",
                           gather_to_all ? "" : ", input read by bands of rows");
  res.cycle = o.cycle;
  res.smoother = o.smoother;
  res.hard_cells = size_t(totals[1]);
  res.cycles = int(iters);
  res.residuals = {1.0, double(rel)};
  res.converged = double(rel) <= o.tolerance;
  res.setup_ms = t_setup - t0;
  res.solve_ms = t_solved - t_setup;
  res.total_ms = now_ms() - t0;
  return res;
}

}  // namespace hypre
#endif

}  // namespace terracl
