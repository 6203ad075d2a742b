// Mixed-precision iterative refinement of the level-0 solution (host/src/multigrid/refine.cpp,
// docs/reconstruct.md): the solution is accumulated in double, its residual is computed in double,
// and the float32 multigrid only solves for the correction. Needs cl_khr_fp64; the host compiles
// this file only on devices that report it.
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

// U = (double) u over the whole grid (hard cells included: they keep value - m).
__kernel void refine_widen(__global double* U, __global const float* u, const int W, const int H) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) U[o + x] = (double)u[o + x];
}

// Residual of U in double, r = g + sum_n w_n (U_n - U) at free cells (the same 5-point operator as
// res0 in multigrid.cl), written as the correction problem for the float multigrid: gc = (float) r
// at free cells, NaN at hard cells, and a zero initial correction uc everywhere. rows[y] = sum of
// r^2 over the row.
__kernel void refine_residual(__global const double* U, __global const float* g, const int W, const int H,
                              const double wx, const double wy, __global float* gc, __global float* uc,
                              __global double* rows) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  const double wn = (y > 0) ? wy : 0.0, ws = (y + 1 < H) ? wy : 0.0;
  __global const double* row = U + o;
  __global const double* up = (y > 0) ? row - W : row;
  __global const double* dn = (y + 1 < H) ? row + W : row;
  double s = 0.0;
  for (int x = 0; x < W; ++x) {
    const float gi = g[o + x];
    uc[o + x] = 0.0f;
    if (isnan(gi)) {
      gc[o + x] = gi;
      continue;
    }
    const double c = row[x];
    const double wl = (x > 0) ? wx : 0.0, wr = (x + 1 < W) ? wx : 0.0;
    const double l = (x > 0) ? row[x - 1] : c, r = (x + 1 < W) ? row[x + 1] : c;
    const double res = (double)gi + wl * (l - c) + wr * (r - c) + wn * (up[x] - c) + ws * (dn[x] - c);
    gc[o + x] = (float)res;
    s += res * res;
  }
  rows[y] = s;
}

// Flexible CG on top of the refinement (issue 19 point 6; Notay's FCG(1)): the float V-cycle's
// answer c to the residual r is the preconditioned residual, the search direction is
// d = c - beta d_prev (A-orthogonal to the previous one) and U moves by alpha d with
// alpha = (d, r) / (d, A d). On sparse-constraint problems the V-cycle alone contracts the
// error only 0.45-0.65 per cycle (the smoothest mode is under-corrected); CG removes that mode.
// A is the level-0 5-point operator on free cells (hard cells: no unknown, d = 0 there). Directions
// are float (like c); the sums are double.

// A-weighted 5-point stencil of `v` at free cell (x, y): sum_n w_n (v - v_n) (v_n = 0 at hard cells).
#define AV(v, o, x, y)                                                                     \
  (((x) > 0 ? wx * ((double)v[o] - (double)v[o - 1]) : 0.0) +                             \
   ((x) + 1 < W ? wx * ((double)v[o] - (double)v[o + 1]) : 0.0) +                         \
   ((y) > 0 ? wy * ((double)v[o] - (double)v[o - W]) : 0.0) +                             \
   ((y) + 1 < H ? wy * ((double)v[o] - (double)v[o + W]) : 0.0))

// sums[y] = sum over the row's free cells of c (A d_prev) (beta's numerator).
__kernel void refine_fcg_beta(__global const float* c, __global const float* dp, __global const float* gc,
                              const int W, const int H, const double wx, const double wy,
                              __global double* sums) {
  const int y = get_global_id(0);
  if (y >= H) return;
  double s = 0.0;
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    if (isnan(gc[o])) continue;
    s += (double)c[o] * AV(dp, o, x, y);
  }
  sums[y] = s;
}

// d = c - beta d_prev at free cells, 0 at hard cells (c and d_prev are 0 there).
__kernel void refine_fcg_direction(__global const float* c, __global const float* dp, const double beta,
                                   __global float* d, const int W, const int H) {
  const int y = get_global_id(0);
  if (y >= H) return;
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    d[o] = (float)((double)c[o] - beta * (double)dp[o]);
  }
}

// sums[2y] = sum d r, sums[2y + 1] = sum d (A d) over the row's free cells (alpha; r = gc, the
// residual the V-cycle was given).
__kernel void refine_step_sums(__global const float* d, __global const float* gc, const int W, const int H,
                               const double wx, const double wy, __global double* sums) {
  const int y = get_global_id(0);
  if (y >= H) return;
  double dr = 0.0, dad = 0.0;
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    const float r = gc[o];
    if (isnan(r)) continue;
    dr += (double)d[o] * (double)r;
    dad += (double)d[o] * AV(d, o, x, y);
  }
  sums[2 * (size_t)y] = dr;
  sums[2 * (size_t)y + 1] = dad;
}
#undef AV

// U += alpha uc at free cells (the float correction, accumulated in double). Per row, for the
// host's stop rule: stats[3y] = max |alpha uc| over free cells, stats[3y+1] / [3y+2] = min / max of U.
__kernel void refine_accumulate(__global double* U, __global const float* uc, __global const float* g, const int W,
                                const int H, const double alpha, __global double* stats) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  double cmax = 0.0, lo = (double)INFINITY, hi = -(double)INFINITY;
  for (int x = 0; x < W; ++x) {
    double v = U[o + x];
    if (!isnan(g[o + x])) {
      const double c = alpha * (double)uc[o + x];
      v += c;
      U[o + x] = v;
      cmax = fmax(cmax, fabs(c));
    }
    lo = fmin(lo, v);
    hi = fmax(hi, v);
  }
  stats[3 * (size_t)y] = cmax;
  stats[3 * (size_t)y + 1] = lo;
  stats[3 * (size_t)y + 2] = hi;
}

// u = (float) U: the refined solution back into the solver's float buffer.
__kernel void refine_narrow(__global float* u, __global const double* U, const int W, const int H) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) u[o + x] = (float)U[o + x];
}
