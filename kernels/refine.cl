// SPDX-License-Identifier: Apache-2.0
// Mixed-precision iterative refinement of the level-0 solution (host/src/reconstruct/refine.cpp,
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
// at free cells, NaN at hard cells, and a zero initial correction uc everywhere; R = r in double
// (refine_accumulate carries it on). rows[y] = sum of r^2 over the row.
__kernel void refine_residual(__global const double* U, __global const float* g, const int W, const int H,
                              const double wx, const double wy, __global float* gc, __global float* uc,
                              __global double* rows, __global double* R) {
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
    R[o + x] = res;
    s += res * res;
  }
  rows[y] = s;
}

// Flexible CG on top of the refinement (Notay's FCG(1)): the float V-cycle's
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

// One pass gives every scalar of the step (per row, over free cells, r = gc the residual the
// V-cycle was given, q = A d_prev kept from the last step): sums[5y..5y+4] = (c, r), (d_prev, r),
// (c, A c), (c, q), (d_prev, q). The host forms beta = (c, q) / (d_prev, q) and, for
// d = c - beta d_prev, (d, r) and (d, A d) = (c, A c) - 2 beta (c, q) + beta^2 (d_prev, q). A c goes
// to `ac` (float) for refine_accumulate: one 5-point stencil per cell and step in all.
__kernel void refine_fcg_sums(__global const float* c, __global const float* dp, __global const float* q,
                              __global const float* gc, const int W, const int H, const double wx,
                              const double wy, __global float* ac, __global double* sums) {
  const int y = get_global_id(0);
  if (y >= H) return;
  double cr = 0.0, dr = 0.0, cac = 0.0, cq = 0.0, dq = 0.0;
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    const float r = gc[o];
    if (isnan(r)) {
      ac[o] = 0.0f;
      continue;
    }
    const double cv = (double)c[o], dv = (double)dp[o], qv = (double)q[o], acv = AV(c, o, x, y);
    ac[o] = (float)acv;
    cr += cv * (double)r;
    dr += dv * (double)r;
    cac += cv * acv;
    cq += cv * qv;
    dq += dv * qv;
  }
  sums[5 * (size_t)y] = cr;
  sums[5 * (size_t)y + 1] = dr;
  sums[5 * (size_t)y + 2] = cac;
  sums[5 * (size_t)y + 3] = cq;
  sums[5 * (size_t)y + 4] = dq;
}

// d = c - beta d_prev and q = A d = A c - beta q_prev, each written in place over what it replaces
// at the same cell (`dq_ac`: A c in, d out; `q`: q_prev in, q out; 0 at hard cells), U += alpha d
// at free cells (accumulated in double) and the residual of the new U by recurrence, R -= alpha q
// (double; the next correction problem: gc = (float) R at free cells; the host zeroes c
// afterwards). Per row: stats[4y] = max |alpha d| over free cells (the stop rule),
// stats[4y+1] / [4y+2] = min / max of U, stats[4y+3] = sum of R^2 (the residual norm).
__kernel void refine_accumulate(__global double* U, __global const float* c, __global float* dp,
                                const double beta, __global float* ac_d, __global float* q,
                                __global const float* g, const int W, const int H, const double alpha,
                                __global double* stats, __global double* R, __global float* gc) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o0 = (size_t)y * W;
  double cmax = 0.0, lo = (double)INFINITY, hi = -(double)INFINITY, ss = 0.0;
  for (int x = 0; x < W; ++x) {
    const size_t o = o0 + x;
    double v = U[o];
    if (!isnan(g[o])) {
      const double dv = (double)c[o] - beta * (double)dp[o];
      const double adv = (double)ac_d[o] - beta * (double)q[o];
      ac_d[o] = (float)dv;
      q[o] = (float)adv;
      const double step = alpha * dv;
      v += step;
      U[o] = v;
      cmax = fmax(cmax, fabs(step));
      const double r = R[o] - alpha * adv;
      R[o] = r;
      gc[o] = (float)r;
      ss += r * r;
    } else {
      ac_d[o] = 0.0f;
      q[o] = 0.0f;
    }
    lo = fmin(lo, v);
    hi = fmax(hi, v);
  }
  stats[4 * (size_t)y] = cmax;
  stats[4 * (size_t)y + 1] = lo;
  stats[4 * (size_t)y + 2] = hi;
  stats[4 * (size_t)y + 3] = ss;
}
#undef AV

// u = (float) U: the refined solution back into the solver's float buffer.
__kernel void refine_narrow(__global float* u, __global const double* U, const int W, const int H) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) u[o + x] = (float)U[o + x];
}
