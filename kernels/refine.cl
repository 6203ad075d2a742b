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

// Step length of the correction c = uc (the float multigrid's answer to the residual gc): per row
// sums[2y] = sum c r, sums[2y + 1] = sum c (A c) over free cells, with A the level-0 5-point operator
// (c = 0 at hard cells: the cycles never touch them). alpha = (c, r) / (c, A c) minimises the energy
// norm of the error along c; on sparse-constraint problems the V-cycle under-corrects the smoothest
// error mode, which alpha restores (docs/reconstruct.md).
__kernel void refine_step_sums(__global const float* uc, __global const float* gc, const int W, const int H,
                               const double wx, const double wy, __global double* sums) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  double cr = 0.0, cac = 0.0;
  for (int x = 0; x < W; ++x) {
    const float r = gc[o + x];
    if (isnan(r)) continue;
    const double c = (double)uc[o + x];
    double ac = 0.0;
    if (x > 0) ac += wx * (c - (double)uc[o + x - 1]);
    if (x + 1 < W) ac += wx * (c - (double)uc[o + x + 1]);
    if (y > 0) ac += wy * (c - (double)uc[o + x - W]);
    if (y + 1 < H) ac += wy * (c - (double)uc[o + x + W]);
    cr += c * (double)r;
    cac += c * ac;
  }
  sums[2 * (size_t)y] = cr;
  sums[2 * (size_t)y + 1] = cac;
}

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
