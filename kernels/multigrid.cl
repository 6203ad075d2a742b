// SPDX-License-Identifier: Apache-2.0
// Geometric multigrid for -Laplacian(u) = g with hard (Dirichlet) cells, on any W x H grid.
//
// Level 0 (the user's grid): 5-point operator with weights wx = 1/cx^2, wy = 1/cy^2 between in-grid
// neighbours (natural Neumann border), hard cells marked by g = NaN (their u is the fixed value).
// Coarse levels are vertex-centred: coarse node I sits on fine node 2I, n_c = n/2 + 1, so fine nodes
// past the border are simply absent (no padding of the user's grid). Their operators are Galerkin
// products P^T A P with bilinear P zeroed at hard nodes, stored in "edge form" as five planes
// [D, wE, wS, wSE, wSW] (diagonal, and the weights -A of the forward edges; the other four come
// from the neighbours). A coarse node with D == 0 is "dead" (every fine node under it is hard).
// Coarse arrays carry a one-node ghost frame of zeros (pitch W+2), so their stencil loops need no
// bounds tests: ghost nodes have e = 0 and zero weights.
//
// Layout (kernels/launch.clh): the cell kernels are written once per cell inside FOR_X; the rows
// shape (PoCL) loops over a row per work-item, the wide shape (GPUs) runs one work-item per cell
// with x fastest (coalesced). Both give the same bits. Reductions (norms, row sums) stay one
// work-item per row. The host never waits between kernels of a cycle. FMA contraction off:
// results do not depend on the compiler.
#pragma OPENCL FP_CONTRACT OFF
#include "launch.clh"
#include "stencil9.clh"
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double acc_t;
#else
typedef float acc_t;
#endif

// Index of node (x, y) in a ghosted coarse array of pitch P = W + 2.
#define GI(x, y, P) ((size_t)((y) + 1) * (size_t)(P) + (size_t)((x) + 1))

// ---------------------------------------------------------------------------------------------
// Level 0: 5-point operator, hard cells = NaN in g.

// Residual g - A u at column x of a level-0 row. `un`/`us` are the rows above/below (aliasing
// the row itself with weight 0 at the grid border). Difference form, g + sum_n w_n (u_n - u): the
// difference of two nearby values is exact in float (Sterbenz), so the residual keeps its accuracy
// far below the float32 floor of u itself. (The value form sum_n w_n u_n - k u u cancels terms of
// size ~|u| w and would need double; badly conditioned cases, e.g. one anchor cell, then keep a
// large smooth error.)
inline float res0(__global const float* ur, __global const float* un, __global const float* us,
                  __global const float* gr, int x, int W, float wx, float wn, float ws) {
  const float gv = gr[x];
  if (isnan(gv)) return 0.0f;
  const float c = ur[x];
  float r = gv + wn * (un[x] - c) + ws * (us[x] - c);
  if (x > 0) r += wx * (ur[x - 1] - c);
  if (x + 1 < W) r += wx * (ur[x + 1] - c);
  return r;
}

// The same for 16 columns x .. x + 15, all with both x neighbours in the grid.
inline float16 res0_v16(__global const float* ur, __global const float* un, __global const float* us,
                        __global const float* gr, int x, float wx, float wn, float ws) {
  const float16 c = vload16(0, ur + x), gv = vload16(0, gr + x);
  const float16 r = gv + wx * (vload16(0, ur + x - 1) - c) + wx * (vload16(0, ur + x + 1) - c) +
                    wn * (vload16(0, un + x) - c) + ws * (vload16(0, us + x) - c);
  return select(r, (float16)(0.0f), isnan(gv));
}

// One lane of res0_v16 as a scalar (its order of additions: left, right, north, south), for an
// interior column: the wide shape's restriction gives the cells the rows shape computes in
// vectors the same bits.
inline float res0_vo(__global const float* ur, __global const float* un, __global const float* us,
                     __global const float* gr, int x, float wx, float wn, float ws) {
  const float gv = gr[x];
  if (isnan(gv)) return 0.0f;
  const float c = ur[x];
  return gv + wx * (ur[x - 1] - c) + wx * (ur[x + 1] - c) + wn * (un[x] - c) + ws * (us[x] - c);
}

// Red-black Gauss-Seidel half-sweep on level 0: cells with (x + y) % 2 == colour.
__kernel void smooth_rb0(__global float* u, __global const float* g, const int W, const int H, const float wx,
                         const float wy, const int colour) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global float* row = u + o;
  __global const float* gr = g + o;
  __global const float* up = (y > 0) ? row - W : row;
  __global const float* dn = (y + 1 < H) ? row + W : row;
  const float wn = (y > 0) ? wy : 0.0f, ws = (y + 1 < H) ? wy : 0.0f;
  const float dy = wn + ws;
#ifdef TERRACL_WIDE
  // One cell of the colour per work-item (x = 2 gid + parity): the same three formulas as the
  // row loop below, picked by column.
  const int x = 2 * (int)get_global_id(0) + ((y + colour) & 1);
  if (x >= W) return;
  const float gv = gr[x];
  if (x == 0) {
    const float wr = W > 1 ? wx : 0.0f;
    const float d = dy + wr;
    if (!isnan(gv) && d > 0.0f) row[0] = (gv + wr * (W > 1 ? row[1] : 0.0f) + wn * up[0] + ws * dn[0]) / d;
  } else if (x < W - 1) {
    const float inv = 1.0f / (dy + 2.0f * wx);
    const float v = (gv + wx * (row[x - 1] + row[x + 1]) + wn * up[x] + ws * dn[x]) * inv;
    row[x] = isnan(gv) ? row[x] : v;
  } else {
    const float d = dy + wx;
    if (!isnan(gv) && d > 0.0f) row[x] = (gv + wx * row[x - 1] + wn * up[x] + ws * dn[x]) / d;
  }
#else
  int x = (y + colour) & 1;
  // The border columns take the general path; the interior loop has no bounds tests.
  if (x == 0) {
    const float gv = gr[0];
    const float wr = W > 1 ? wx : 0.0f;
    const float d = dy + wr;
    if (!isnan(gv) && d > 0.0f) row[0] = (gv + wr * (W > 1 ? row[1] : 0.0f) + wn * up[0] + ws * dn[0]) / d;
    x += 2;
  }
  const float inv = 1.0f / (dy + 2.0f * wx);
  for (; x < W - 1; x += 2) {
    const float gv = gr[x];
    const float v = (gv + wx * (row[x - 1] + row[x + 1]) + wn * up[x] + ws * dn[x]) * inv;
    row[x] = isnan(gv) ? row[x] : v;
  }
  if (x == W - 1 && W > 1) {
    const float gv = gr[x];
    const float d = dy + wx;
    if (!isnan(gv) && d > 0.0f) row[x] = (gv + wx * row[x - 1] + wn * up[x] + ws * dn[x]) / d;
  }
#endif
}

// Weighted Jacobi on level 0: out = u + omega * (GS value - u).
__kernel void jacobi0(__global float* out, __global const float* u, __global const float* g, const int W, const int H,
                      const float wx, const float wy, const float omega) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* row = u + o;
  __global const float* up = (y > 0) ? row - W : row;
  __global const float* dn = (y + 1 < H) ? row + W : row;
  const float wn = (y > 0) ? wy : 0.0f, ws = (y + 1 < H) ? wy : 0.0f;
  FOR_X(x, W) {
    const float wl = x > 0 ? wx : 0.0f, wr = x + 1 < W ? wx : 0.0f;
    const float d = wl + wr + wn + ws;
    const float uc = row[x];
    const float r = res0(row, up, dn, g + o, x, W, wx, wn, ws);
    out[o + x] = d > 0.0f ? uc + omega * r / d : uc;
  }
}

// Full-weighting restriction of the level-0 residual to coarse row j (fused: the fine residual is
// never stored), and zero initial guess for the coarse correction.
__kernel void residual_restrict0(__global const float* u, __global const float* g, const int W, const int H,
                                 const float wx, const float wy, __global float* rc, __global float* ec, const int Wc) {
  const int j = ROW_ID();
  const int Hc = H / 2 + 1;
  if (j >= Hc) return;
  const int P = Wc + 2;
  // Fine rows 2j-1, 2j, 2j+1 with full-weighting factors a0, a1, a2 (0 outside the grid).
#define ROW(k, yy, av)                                                           \
  const int y##k = clamp(yy, 0, H - 1);                                          \
  const float a##k = (yy) >= 0 && (yy) < H ? (av) : 0.0f;                        \
  __global const float* ur##k = u + (size_t)y##k * W;                            \
  __global const float* gr##k = g + (size_t)y##k * W;                            \
  __global const float* un##k = y##k > 0 ? ur##k - W : ur##k;                    \
  __global const float* us##k = y##k + 1 < H ? ur##k + W : ur##k;                \
  const float wn##k = y##k > 0 ? wy : 0.0f, ws##k = y##k + 1 < H ? wy : 0.0f;
  ROW(0, 2 * j - 1, 0.5f)
  ROW(1, 2 * j, 1.0f)
  ROW(2, 2 * j + 1, 0.5f)
#undef ROW
#define COL(xx)                                                                  \
  (a0 * res0(ur0, un0, us0, gr0, xx, W, wx, wn0, ws0) + a1 * res0(ur1, un1, us1, gr1, xx, W, wx, wn1, ws1) + \
   a2 * res0(ur2, un2, us2, gr2, xx, W, wx, wn2, ws2))
#ifdef TERRACL_WIDE
  // One coarse node per work-item; column 2i-1 (the row loop's carried `prev`) is recomputed.
  // Each column is computed as the row loop computes it: nodes in the loop's 8-node vector blocks
  // (from node 1, while the block's fine columns are all inside) with res0_v16's order, the rest
  // with res0's; column 2i-1 belongs to node i-1.
#define COLV(xx)                                                                \
  (a0 * res0_vo(ur0, un0, us0, gr0, xx, wx, wn0, ws0) + a1 * res0_vo(ur1, un1, us1, gr1, xx, wx, wn1, ws1) + \
   a2 * res0_vo(ur2, un2, us2, gr2, xx, wx, wn2, ws2))
#define VEC(n) ((n) >= 1 && 1 + 8 * (((n) - 1) / 8) + 8 <= Wc && 2 * (1 + 8 * (((n) - 1) / 8)) + 16 <= W - 1)
  const int i = get_global_id(0);
  if (i >= Wc) return;
  const float prev = (i > 0 && 2 * i - 1 < W) ? (VEC(i - 1) ? COLV(2 * i - 1) : COL(2 * i - 1)) : 0.0f;
  const int v = VEC(i);
  const float c0 = 2 * i < W ? (v ? COLV(2 * i) : COL(2 * i)) : 0.0f;
  const float c1 = 2 * i + 1 < W ? (v ? COLV(2 * i + 1) : COL(2 * i + 1)) : 0.0f;
  rc[GI(i, j, P)] = 0.5f * prev + c0 + 0.5f * c1;
  ec[GI(i, j, P)] = 0.0f;
#undef VEC
#undef COLV
#else
  float prev = 0.0f;  // column 2i-1
  int i = 0;
  for (;;) {
    // Eight coarse nodes at a time where fine columns 2i-1 .. 2i+16 are all in the grid: the fine
    // residuals of 16 columns in vectors, split into even (2i) and odd (2i+1) columns.
    for (; i >= 1 && i + 8 <= Wc && 2 * i + 16 <= W - 1; i += 8) {
      const int x = 2 * i;
      const float16 c = a0 * res0_v16(ur0, un0, us0, gr0, x, wx, wn0, ws0) +
                        a1 * res0_v16(ur1, un1, us1, gr1, x, wx, wn1, ws1) +
                        a2 * res0_v16(ur2, un2, us2, gr2, x, wx, wn2, ws2);
      const float8 ce = c.even, co = c.odd;
      const float8 cm = (float8)(prev, co.s012, co.s3456);
      vstore8(0.5f * cm + ce + 0.5f * co, 0, rc + GI(i, j, P));
      vstore8((float8)(0.0f), 0, ec + GI(i, j, P));
      prev = co.s7;
    }
    if (i >= Wc) break;
    const float c0 = 2 * i < W ? COL(2 * i) : 0.0f;
    const float c1 = 2 * i + 1 < W ? COL(2 * i + 1) : 0.0f;
    rc[GI(i, j, P)] = 0.5f * prev + c0 + 0.5f * c1;
    ec[GI(i, j, P)] = 0.0f;
    prev = c1;
    ++i;
  }
#endif
#undef COL
}

// u += P ec on free cells of level 0 (ec ghosted, pitch Wc + 2).
__kernel void prolong_correct0(__global float* u, __global const float* g, const int W, const int H,
                               __global const float* ec, const int Wc) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  const int P = Wc + 2;
  __global const float* r0 = ec + GI(0, y >> 1, P);
  __global const float* r1 = (y & 1) ? r0 + P : r0;
  FOR_X(x, W) {
    const int xc = x >> 1;
    const float v = (x & 1) ? 0.25f * (r0[xc] + r0[xc + 1] + r1[xc] + r1[xc + 1]) : 0.5f * (r0[xc] + r1[xc]);
    const float gv = g[o + x];
    u[o + x] = isnan(gv) ? u[o + x] : u[o + x] + v;
  }
}

// Per-row sums of squared level-0 residuals (the host adds the rows in double).
// Per row: the sum of squared residuals (rows[y]) and the expected sum of squared residuals that
// float32 rounding of u alone produces (rows[H + y]): each u_j is off by up to half an ulp
// (variance ulp^2 / 12), and cell i's residual sums a_ij times those errors. No smoother can get
// below that floor, so the host stops cycling once the residual is within a few times it.
__kernel void residual_norm0(__global const float* u, __global const float* g, const int W, const int H,
                             const float wx, const float wy, __global float* rows) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* row = u + o;
  __global const float* gr = g + o;
  __global const float* up = (y > 0) ? row - W : row;
  __global const float* dn = (y + 1 < H) ? row + W : row;
  const float wn = (y > 0) ? wy : 0.0f, ws = (y + 1 < H) ? wy : 0.0f;
  // Floor weight of an interior cell, (sum of the stencil's squared weights) / 12 * (2^-23)^2.
  const float di = 2.0f * wx + wn + ws;
  const float ki = (di * di + 2.0f * wx * wx + wn * wn + ws * ws) * (1.0f / 12.0f) * 1.4210855e-14f;
  float16 sv = (float16)(0.0f), fv = (float16)(0.0f);
  int x = 1;
  for (; x + 16 <= W - 1; x += 16) {
    const float16 r = res0_v16(row, up, dn, gr, x, wx, wn, ws);
    const float16 c = vload16(0, row + x);
    sv += r * r;
    fv += select(c * c, (float16)(0.0f), isnan(vload16(0, gr + x)));
  }
  float s = 0.0f, f = 0.0f;
  s = sv.s0 + sv.s1 + sv.s2 + sv.s3 + sv.s4 + sv.s5 + sv.s6 + sv.s7 + sv.s8 + sv.s9 + sv.sa + sv.sb + sv.sc + sv.sd +
      sv.se + sv.sf;
  f = ki * (fv.s0 + fv.s1 + fv.s2 + fv.s3 + fv.s4 + fv.s5 + fv.s6 + fv.s7 + fv.s8 + fv.s9 + fv.sa + fv.sb + fv.sc +
            fv.sd + fv.se + fv.sf);
  // The rest of the row, and the border columns with their own stencil weights.
  for (int k = 0; k < W; k = (k == 0 ? x : k + 1)) {
    const float r = res0(row, up, dn, gr, k, W, wx, wn, ws);
    s += r * r;
    if (!isnan(gr[k])) {
      const float wl = k > 0 ? wx : 0.0f, wr = k + 1 < W ? wx : 0.0f;
      const float d = wl + wr + wn + ws;
      f += (d * d + wl * wl + wr * wr + wn * wn + ws * ws) * (1.0f / 12.0f) * 1.4210855e-14f * row[k] * row[k];
    }
  }
  rows[y] = s;
  rows[H + y] = f;
}

// Same for the trivial guess (free cells read as 0): the norm of the reduced right-hand side.
__kernel void rhs_norm0(__global const float* u, __global const float* g, const int W, const int H, const float wx,
                        const float wy, __global float* rows) {
  const int y = get_global_id(0);
  if (y >= H) return;
  acc_t s = 0;
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    const float gv = g[o];
    if (isnan(gv)) continue;
    acc_t r = gv;
#define HARD_NB(cond, off, w) \
  if ((cond) && isnan(g[o + (off)])) r += (acc_t)(w) * (acc_t)u[o + (off)];
    HARD_NB(x > 0, -1, wx)
    HARD_NB(x + 1 < W, 1, wx)
    HARD_NB(y > 0, -(long)W, wy)
    HARD_NB(y + 1 < H, (long)W, wy)
#undef HARD_NB
    s += r * r;
  }
  rows[y] = (float)s;
}

// Warm start: u holds the uploaded initial heightfield; make it the deviation from m.
__kernel void shift_level0(__global float* u, const int W, const int H, const float m) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) u[o + x] -= m;
}

// Hard cells from the sparse list (flat index, value): u = value - m, g = NaN marks them hard.
// Work-item k handles entries [k * chunk, (k + 1) * chunk).
__kernel void scatter_hard(__global float* u, __global float* g, __global const uint* index,
                           __global const float* value, const int n, const int chunk, const float m) {
  const int k = get_global_id(0);
  const int end = min(n, (k + 1) * chunk);
  for (int i = k * chunk; i < end; ++i) {
    const uint c = index[i];
    u[c] = value[i] - m;
    g[c] = NAN;
  }
}

// g -= delta on free cells (projection onto the range of the singular pure-Neumann operator).
__kernel void shift_free(__global float* g, const int W, const int H, const float delta) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) {
    const float v = g[o + x];
    if (!isnan(v)) g[o + x] = v - delta;
  }
}

// Per-row sums of g over free cells, for the mean in the singular case.
__kernel void row_sums(__global const float* g, const int W, const int H, __global float* sums) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  acc_t s = 0;
  for (int x = 0; x < W; ++x) {
    const float v = g[o + x];
    if (!isnan(v)) s += v;
  }
  sums[y] = (float)s;
}

// ---------------------------------------------------------------------------------------------
// Coarse levels: 9-point Galerkin operators in edge form, ghosted planes [D, wE, wS, wSE, wSW]
// (+ s for the next Galerkin product), each of N = (W+2)(H+2) floats.

// Residual r - A e at ghosted index o (pitch P, plane size N).
inline float res9(__global const float* e, __global const float* r, __global const float* st, size_t o, int P,
                  size_t N) {
  STENCIL9_RESIDUAL(e, r, st, o, P, N)
}

// Gauss-Seidel on a 9-point level over rows y % 2 == py (rows of one parity only couple to the
// other parity). xstep 2: four-colour ordering (nodes x % 2 == px independent, vectorisable);
// xstep 1: zebra ordering, each row swept left to right (half the launches, for small levels
// where the launch cost dominates).
__kernel void smooth9(__global float* e, __global const float* r, __global const float* st, const int W, const int H,
                      const int px, const int py, const int xstep) {
  const int y = 2 * ROW_ID() + py;
  if (y >= H) return;
  const int P = W + 2;
  const size_t N = (size_t)P * (H + 2);
#ifdef TERRACL_WIDE
  // Four colours: one node per work-item. Zebra rows are sequential along x: the host launches
  // one work-item column for them and the first one sweeps its row as in the rows shape.
  int x = xstep == 2 ? px + 2 * (int)get_global_id(0) : px;
  const int end = xstep == 2 ? min(x + 1, W) : (get_global_id(0) == 0 ? W : 0);
  for (; x < end; x += xstep) {
#else
  for (int x = px; x < W; x += xstep) {
#endif
    const size_t o = GI(x, y, P);
    STENCIL9_SMOOTH_NODE(e, st, o, res9(e, r, st, o, P, N))
  }
}

// Weighted Jacobi on a 9-point level.
__kernel void jacobi9(__global float* out, __global const float* e, __global const float* r,
                      __global const float* st, const int W, const int H, const float omega) {
  const int y = ROW_ID();
  if (y >= H) return;
  const int P = W + 2;
  const size_t N = (size_t)P * (H + 2);
  FOR_X(x, W) {
    const size_t o = GI(x, y, P);
    const float d = st[o];
    out[o] = d > 0.0f ? e[o] + omega * res9(e, r, st, o, P, N) / d : 0.0f;
  }
}

// Restriction of the coarse-level residual (fused), zero initial coarse correction.
__kernel void residual_restrict9(__global const float* e, __global const float* r, __global const float* st,
                                 const int W, const int H, __global float* rc, __global float* ec, const int Wc) {
  const int j = ROW_ID();
  const int Hc = H / 2 + 1;
  if (j >= Hc) return;
  const int P = W + 2, Pc = Wc + 2;
  const size_t N = (size_t)P * (H + 2);
  const float a0 = 2 * j - 1 >= 0 ? 0.5f : 0.0f, a1 = 2 * j < H ? 1.0f : 0.0f, a2 = 2 * j + 1 < H ? 0.5f : 0.0f;
  const int y0 = max(2 * j - 1, 0), y1 = min(2 * j, H - 1), y2 = min(2 * j + 1, H - 1);
#define COL(xx)                                                          \
  ((a0 != 0.0f ? a0 * res9(e, r, st, GI(xx, y0, P), P, N) : 0.0f) +     \
   (a1 != 0.0f ? res9(e, r, st, GI(xx, y1, P), P, N) : 0.0f) +          \
   (a2 != 0.0f ? a2 * res9(e, r, st, GI(xx, y2, P), P, N) : 0.0f))
#ifdef TERRACL_WIDE
  // One coarse node per work-item; column 2i-1 (the row loop's carried `prev`) is recomputed.
  const int i = get_global_id(0);
  if (i < Wc) {
    const float prev = (i > 0 && 2 * i - 1 < W) ? COL(2 * i - 1) : 0.0f;
#else
  float prev = 0.0f;
  for (int i = 0; i < Wc; ++i) {
#endif
    const float c0 = 2 * i < W ? COL(2 * i) : 0.0f;
    const float c1 = 2 * i + 1 < W ? COL(2 * i + 1) : 0.0f;
    rc[GI(i, j, Pc)] = 0.5f * prev + c0 + 0.5f * c1;
    ec[GI(i, j, Pc)] = 0.0f;
#ifndef TERRACL_WIDE
    prev = c1;
#endif
  }
#undef COL
}

// e += P ec on a coarse level (dead nodes are reset to 0 by the smoother).
__kernel void prolong_correct9(__global float* e, const int W, const int H, __global const float* ec, const int Wc) {
  const int y = ROW_ID();
  if (y >= H) return;
  const int P = W + 2, Pc = Wc + 2;
  __global const float* r0 = ec + GI(0, y >> 1, Pc);
  __global const float* r1 = (y & 1) ? r0 + Pc : r0;
  __global float* row = e + GI(0, y, P);
  FOR_X(x, W) {
    const int xc = x >> 1;
    row[x] += (x & 1) ? 0.25f * (r0[xc] + r0[xc + 1] + r1[xc] + r1[xc + 1]) : 0.5f * (r0[xc] + r1[xc]);
  }
}

// Coarsest level: e = pinv(A) r with the pseudo-inverse computed on the host at set-up
// (handles the singular pure-Neumann case and dead nodes). One work-item per row of pinv.
__kernel void coarse_solve(__global float* e, __global const float* r, __global const float* pinv, const int W,
                           const int H) {
  const int i = get_global_id(0);
  const int n = W * H;  // index-ok: the coarsest level has a few hundred nodes
  if (i >= n) return;
  const int P = W + 2;
  float s = 0.0f;
  for (int j = 0; j < n; ++j) s += pinv[(size_t)i * n + j] * r[GI(j % W, j / W, P)];
  e[GI(i % W, i / W, P)] = s;
}

// ---------------------------------------------------------------------------------------------
// Galerkin coarse operators. Generated by scripts/gen_galerkin.py (do not edit by hand).
#define GALERKIN_LOADS \
  const float S_m1_m1 = S(-1, -1); \
  const float S_p0_m1 = S(0, -1); \
  const float S_p1_m1 = S(1, -1); \
  const float S_m1_p0 = S(-1, 0); \
  const float S_p0_p0 = S(0, 0); \
  const float S_p1_p0 = S(1, 0); \
  const float S_m1_p1 = S(-1, 1); \
  const float S_p0_p1 = S(0, 1); \
  const float S_p1_p1 = S(1, 1); \
  const float WE_m2_m1 = WE(-2, -1); \
  const float WE_m1_m1 = WE(-1, -1); \
  const float WE_p0_m1 = WE(0, -1); \
  const float WE_p1_m1 = WE(1, -1); \
  const float WE_m2_p0 = WE(-2, 0); \
  const float WE_m1_p0 = WE(-1, 0); \
  const float WE_p0_p0 = WE(0, 0); \
  const float WE_p1_p0 = WE(1, 0); \
  const float WE_m2_p1 = WE(-2, 1); \
  const float WE_m1_p1 = WE(-1, 1); \
  const float WE_p0_p1 = WE(0, 1); \
  const float WE_p1_p1 = WE(1, 1); \
  const float WS_m1_m2 = WS(-1, -2); \
  const float WS_p0_m2 = WS(0, -2); \
  const float WS_p1_m2 = WS(1, -2); \
  const float WS_m1_m1 = WS(-1, -1); \
  const float WS_p0_m1 = WS(0, -1); \
  const float WS_p1_m1 = WS(1, -1); \
  const float WS_m1_p0 = WS(-1, 0); \
  const float WS_p0_p0 = WS(0, 0); \
  const float WS_p1_p0 = WS(1, 0); \
  const float WS_m1_p1 = WS(-1, 1); \
  const float WS_p0_p1 = WS(0, 1); \
  const float WS_p1_p1 = WS(1, 1); \
  const float WSE_m2_m2 = WSE(-2, -2); \
  const float WSE_m1_m2 = WSE(-1, -2); \
  const float WSE_p0_m2 = WSE(0, -2); \
  const float WSE_m2_m1 = WSE(-2, -1); \
  const float WSE_m1_m1 = WSE(-1, -1); \
  const float WSE_p1_m1 = WSE(1, -1); \
  const float WSE_m2_p0 = WSE(-2, 0); \
  const float WSE_p0_p0 = WSE(0, 0); \
  const float WSE_p1_p0 = WSE(1, 0); \
  const float WSE_m1_p1 = WSE(-1, 1); \
  const float WSE_p0_p1 = WSE(0, 1); \
  const float WSE_p1_p1 = WSE(1, 1); \
  const float WSW_p0_m2 = WSW(0, -2); \
  const float WSW_p1_m2 = WSW(1, -2); \
  const float WSW_p2_m2 = WSW(2, -2); \
  const float WSW_m1_m1 = WSW(-1, -1); \
  const float WSW_p1_m1 = WSW(1, -1); \
  const float WSW_p2_m1 = WSW(2, -1); \
  const float WSW_m1_p0 = WSW(-1, 0); \
  const float WSW_p0_p0 = WSW(0, 0); \
  const float WSW_p2_p0 = WSW(2, 0); \
  const float WSW_m1_p1 = WSW(-1, 1); \
  const float WSW_p0_p1 = WSW(0, 1); \
  const float WSW_p1_p1 = WSW(1, 1); \
  (void)0
#define GALERKIN_D ( \
      0.0625f * WSE_m2_m2 \
    + 0.0625f * WS_m1_m2 \
    + 0.25f * WSE_m1_m2 \
    + 0.25f * WS_p0_m2 \
    + 0.0625f * WSE_p0_m2 \
    + 0.0625f * WSW_p0_m2 \
    + 0.0625f * WS_p1_m2 \
    + 0.25f * WSW_p1_m2 \
    + 0.0625f * WSW_p2_m2 \
    + 0.0625f * WE_m2_m1 \
    + 0.25f * WSE_m2_m1 \
    + 0.0625f * S_m1_m1 \
    + 0.0625f * WE_m1_m1 \
    + 0.0625f * WS_m1_m1 \
    + 0.5625f * WSE_m1_m1 \
    + 0.0625f * WSW_m1_m1 \
    + 0.25f * S_p0_m1 \
    + 0.0625f * WE_p0_m1 \
    + 0.25f * WS_p0_m1 \
    + 0.0625f * S_p1_m1 \
    + 0.0625f * WE_p1_m1 \
    + 0.0625f * WS_p1_m1 \
    + 0.0625f * WSE_p1_m1 \
    + 0.5625f * WSW_p1_m1 \
    + 0.25f * WSW_p2_m1 \
    + 0.25f * WE_m2_p0 \
    + 0.0625f * WSE_m2_p0 \
    + 0.25f * S_m1_p0 \
    + 0.25f * WE_m1_p0 \
    + 0.0625f * WS_m1_p0 \
    + 0.25f * WSW_m1_p0 \
    + 1.0f * S_p0_p0 \
    + 0.25f * WE_p0_p0 \
    + 0.25f * WS_p0_p0 \
    + 0.5625f * WSE_p0_p0 \
    + 0.5625f * WSW_p0_p0 \
    + 0.25f * S_p1_p0 \
    + 0.25f * WE_p1_p0 \
    + 0.0625f * WS_p1_p0 \
    + 0.25f * WSE_p1_p0 \
    + 0.0625f * WSW_p2_p0 \
    + 0.0625f * WE_m2_p1 \
    + 0.0625f * S_m1_p1 \
    + 0.0625f * WE_m1_p1 \
    + 0.0625f * WS_m1_p1 \
    + 0.0625f * WSE_m1_p1 \
    + 0.0625f * WSW_m1_p1 \
    + 0.25f * S_p0_p1 \
    + 0.0625f * WE_p0_p1 \
    + 0.25f * WS_p0_p1 \
    + 0.25f * WSE_p0_p1 \
    + 0.25f * WSW_p0_p1 \
    + 0.0625f * S_p1_p1 \
    + 0.0625f * WE_p1_p1 \
    + 0.0625f * WS_p1_p1 \
    + 0.0625f * WSE_p1_p1 \
    + 0.0625f * WSW_p1_p1 \
  )
#define GALERKIN_WE ( \
      -0.0625f * WSE_p0_m2 \
    + -0.0625f * WS_p1_m2 \
    + -0.0625f * WSW_p2_m2 \
    + 0.0625f * WE_p0_m1 \
    + -0.0625f * S_p1_m1 \
    + 0.0625f * WE_p1_m1 \
    + -0.0625f * WS_p1_m1 \
    + 0.1875f * WSE_p1_m1 \
    + 0.1875f * WSW_p1_m1 \
    + 0.25f * WE_p0_p0 \
    + 0.1875f * WSE_p0_p0 \
    + -0.25f * S_p1_p0 \
    + 0.25f * WE_p1_p0 \
    + -0.0625f * WS_p1_p0 \
    + 0.1875f * WSW_p2_p0 \
    + 0.0625f * WE_p0_p1 \
    + -0.0625f * S_p1_p1 \
    + 0.0625f * WE_p1_p1 \
    + -0.0625f * WS_p1_p1 \
    + -0.0625f * WSE_p1_p1 \
    + -0.0625f * WSW_p1_p1 \
  )
#define GALERKIN_WS ( \
      -0.0625f * WSE_m2_p0 \
    + 0.0625f * WS_m1_p0 \
    + 0.25f * WS_p0_p0 \
    + 0.1875f * WSE_p0_p0 \
    + 0.1875f * WSW_p0_p0 \
    + 0.0625f * WS_p1_p0 \
    + -0.0625f * WSW_p2_p0 \
    + -0.0625f * WE_m2_p1 \
    + -0.0625f * S_m1_p1 \
    + -0.0625f * WE_m1_p1 \
    + 0.0625f * WS_m1_p1 \
    + 0.1875f * WSE_m1_p1 \
    + -0.0625f * WSW_m1_p1 \
    + -0.25f * S_p0_p1 \
    + -0.0625f * WE_p0_p1 \
    + 0.25f * WS_p0_p1 \
    + -0.0625f * S_p1_p1 \
    + -0.0625f * WE_p1_p1 \
    + 0.0625f * WS_p1_p1 \
    + -0.0625f * WSE_p1_p1 \
    + 0.1875f * WSW_p1_p1 \
  )
#define GALERKIN_WSE ( \
      0.1875f * WSE_p0_p0 \
    + 0.0625f * WS_p1_p0 \
    + 0.25f * WSE_p1_p0 \
    + -0.0625f * WSW_p2_p0 \
    + 0.0625f * WE_p0_p1 \
    + 0.25f * WSE_p0_p1 \
    + -0.0625f * S_p1_p1 \
    + 0.0625f * WE_p1_p1 \
    + 0.0625f * WS_p1_p1 \
    + 0.1875f * WSE_p1_p1 \
    + -0.0625f * WSW_p1_p1 \
  )
#define GALERKIN_WSW ( \
      -0.0625f * WSE_m2_p0 \
    + 0.0625f * WS_m1_p0 \
    + 0.25f * WSW_m1_p0 \
    + 0.1875f * WSW_p0_p0 \
    + 0.0625f * WE_m2_p1 \
    + -0.0625f * S_m1_p1 \
    + 0.0625f * WE_m1_p1 \
    + 0.0625f * WS_m1_p1 \
    + -0.0625f * WSE_m1_p1 \
    + 0.1875f * WSW_m1_p1 \
    + 0.25f * WSW_p0_p1 \
  )
#define GALERKIN0_STATES \
  const int cs_m2_m2 = cell_state(g, bx + (-2), by + (-2), W, H); \
  const int cs_m1_m2 = cell_state(g, bx + (-1), by + (-2), W, H); \
  const int cs_p0_m2 = cell_state(g, bx + (0), by + (-2), W, H); \
  const int cs_p1_m2 = cell_state(g, bx + (1), by + (-2), W, H); \
  const int cs_p2_m2 = cell_state(g, bx + (2), by + (-2), W, H); \
  const int cs_m2_m1 = cell_state(g, bx + (-2), by + (-1), W, H); \
  const int cs_m1_m1 = cell_state(g, bx + (-1), by + (-1), W, H); \
  const int cs_p0_m1 = cell_state(g, bx + (0), by + (-1), W, H); \
  const int cs_p1_m1 = cell_state(g, bx + (1), by + (-1), W, H); \
  const int cs_p2_m1 = cell_state(g, bx + (2), by + (-1), W, H); \
  const int cs_m2_p0 = cell_state(g, bx + (-2), by + (0), W, H); \
  const int cs_m1_p0 = cell_state(g, bx + (-1), by + (0), W, H); \
  const int cs_p0_p0 = cell_state(g, bx + (0), by + (0), W, H); \
  const int cs_p1_p0 = cell_state(g, bx + (1), by + (0), W, H); \
  const int cs_p2_p0 = cell_state(g, bx + (2), by + (0), W, H); \
  const int cs_m2_p1 = cell_state(g, bx + (-2), by + (1), W, H); \
  const int cs_m1_p1 = cell_state(g, bx + (-1), by + (1), W, H); \
  const int cs_p0_p1 = cell_state(g, bx + (0), by + (1), W, H); \
  const int cs_p1_p1 = cell_state(g, bx + (1), by + (1), W, H); \
  const int cs_p2_p1 = cell_state(g, bx + (2), by + (1), W, H); \
  const int cs_m2_p2 = cell_state(g, bx + (-2), by + (2), W, H); \
  const int cs_m1_p2 = cell_state(g, bx + (-1), by + (2), W, H); \
  const int cs_p0_p2 = cell_state(g, bx + (0), by + (2), W, H); \
  const int cs_p1_p2 = cell_state(g, bx + (1), by + (2), W, H); \
  const int cs_p2_p2 = cell_state(g, bx + (2), by + (2), W, H); \
  (void)0
#define GALERKIN0_LOADS \
  const float S_m1_m1 = cs_m1_m1 == 1 ? wx * (float)((cs_m2_m1 == 2) + (cs_p0_m1 == 2)) + wy * (float)((cs_m1_m2 == 2) + (cs_m1_p0 == 2)) : 0.0f; \
  const float S_p0_m1 = cs_p0_m1 == 1 ? wx * (float)((cs_m1_m1 == 2) + (cs_p1_m1 == 2)) + wy * (float)((cs_p0_m2 == 2) + (cs_p0_p0 == 2)) : 0.0f; \
  const float S_p1_m1 = cs_p1_m1 == 1 ? wx * (float)((cs_p0_m1 == 2) + (cs_p2_m1 == 2)) + wy * (float)((cs_p1_m2 == 2) + (cs_p1_p0 == 2)) : 0.0f; \
  const float S_m1_p0 = cs_m1_p0 == 1 ? wx * (float)((cs_m2_p0 == 2) + (cs_p0_p0 == 2)) + wy * (float)((cs_m1_m1 == 2) + (cs_m1_p1 == 2)) : 0.0f; \
  const float S_p0_p0 = cs_p0_p0 == 1 ? wx * (float)((cs_m1_p0 == 2) + (cs_p1_p0 == 2)) + wy * (float)((cs_p0_m1 == 2) + (cs_p0_p1 == 2)) : 0.0f; \
  const float S_p1_p0 = cs_p1_p0 == 1 ? wx * (float)((cs_p0_p0 == 2) + (cs_p2_p0 == 2)) + wy * (float)((cs_p1_m1 == 2) + (cs_p1_p1 == 2)) : 0.0f; \
  const float S_m1_p1 = cs_m1_p1 == 1 ? wx * (float)((cs_m2_p1 == 2) + (cs_p0_p1 == 2)) + wy * (float)((cs_m1_p0 == 2) + (cs_m1_p2 == 2)) : 0.0f; \
  const float S_p0_p1 = cs_p0_p1 == 1 ? wx * (float)((cs_m1_p1 == 2) + (cs_p1_p1 == 2)) + wy * (float)((cs_p0_p0 == 2) + (cs_p0_p2 == 2)) : 0.0f; \
  const float S_p1_p1 = cs_p1_p1 == 1 ? wx * (float)((cs_p0_p1 == 2) + (cs_p2_p1 == 2)) + wy * (float)((cs_p1_p0 == 2) + (cs_p1_p2 == 2)) : 0.0f; \
  const float WE_m2_m1 = (cs_m2_m1 == 1 && cs_m1_m1 == 1) ? wx : 0.0f; \
  const float WE_m1_m1 = (cs_m1_m1 == 1 && cs_p0_m1 == 1) ? wx : 0.0f; \
  const float WE_p0_m1 = (cs_p0_m1 == 1 && cs_p1_m1 == 1) ? wx : 0.0f; \
  const float WE_p1_m1 = (cs_p1_m1 == 1 && cs_p2_m1 == 1) ? wx : 0.0f; \
  const float WE_m2_p0 = (cs_m2_p0 == 1 && cs_m1_p0 == 1) ? wx : 0.0f; \
  const float WE_m1_p0 = (cs_m1_p0 == 1 && cs_p0_p0 == 1) ? wx : 0.0f; \
  const float WE_p0_p0 = (cs_p0_p0 == 1 && cs_p1_p0 == 1) ? wx : 0.0f; \
  const float WE_p1_p0 = (cs_p1_p0 == 1 && cs_p2_p0 == 1) ? wx : 0.0f; \
  const float WE_m2_p1 = (cs_m2_p1 == 1 && cs_m1_p1 == 1) ? wx : 0.0f; \
  const float WE_m1_p1 = (cs_m1_p1 == 1 && cs_p0_p1 == 1) ? wx : 0.0f; \
  const float WE_p0_p1 = (cs_p0_p1 == 1 && cs_p1_p1 == 1) ? wx : 0.0f; \
  const float WE_p1_p1 = (cs_p1_p1 == 1 && cs_p2_p1 == 1) ? wx : 0.0f; \
  const float WS_m1_m2 = (cs_m1_m2 == 1 && cs_m1_m1 == 1) ? wy : 0.0f; \
  const float WS_p0_m2 = (cs_p0_m2 == 1 && cs_p0_m1 == 1) ? wy : 0.0f; \
  const float WS_p1_m2 = (cs_p1_m2 == 1 && cs_p1_m1 == 1) ? wy : 0.0f; \
  const float WS_m1_m1 = (cs_m1_m1 == 1 && cs_m1_p0 == 1) ? wy : 0.0f; \
  const float WS_p0_m1 = (cs_p0_m1 == 1 && cs_p0_p0 == 1) ? wy : 0.0f; \
  const float WS_p1_m1 = (cs_p1_m1 == 1 && cs_p1_p0 == 1) ? wy : 0.0f; \
  const float WS_m1_p0 = (cs_m1_p0 == 1 && cs_m1_p1 == 1) ? wy : 0.0f; \
  const float WS_p0_p0 = (cs_p0_p0 == 1 && cs_p0_p1 == 1) ? wy : 0.0f; \
  const float WS_p1_p0 = (cs_p1_p0 == 1 && cs_p1_p1 == 1) ? wy : 0.0f; \
  const float WS_m1_p1 = (cs_m1_p1 == 1 && cs_m1_p2 == 1) ? wy : 0.0f; \
  const float WS_p0_p1 = (cs_p0_p1 == 1 && cs_p0_p2 == 1) ? wy : 0.0f; \
  const float WS_p1_p1 = (cs_p1_p1 == 1 && cs_p1_p2 == 1) ? wy : 0.0f; \
  const float WSE_m2_m2 = 0.0f; \
  const float WSE_m1_m2 = 0.0f; \
  const float WSE_p0_m2 = 0.0f; \
  const float WSE_m2_m1 = 0.0f; \
  const float WSE_m1_m1 = 0.0f; \
  const float WSE_p1_m1 = 0.0f; \
  const float WSE_m2_p0 = 0.0f; \
  const float WSE_p0_p0 = 0.0f; \
  const float WSE_p1_p0 = 0.0f; \
  const float WSE_m1_p1 = 0.0f; \
  const float WSE_p0_p1 = 0.0f; \
  const float WSE_p1_p1 = 0.0f; \
  const float WSW_p0_m2 = 0.0f; \
  const float WSW_p1_m2 = 0.0f; \
  const float WSW_p2_m2 = 0.0f; \
  const float WSW_m1_m1 = 0.0f; \
  const float WSW_p1_m1 = 0.0f; \
  const float WSW_p2_m1 = 0.0f; \
  const float WSW_m1_p0 = 0.0f; \
  const float WSW_p0_p0 = 0.0f; \
  const float WSW_p2_p0 = 0.0f; \
  const float WSW_m1_p1 = 0.0f; \
  const float WSW_p0_p1 = 0.0f; \
  const float WSW_p1_p1 = 0.0f; \
  (void)0

// Level 0 applies D A D (hard rows/columns removed): an edge to a hard cell becomes diagonal
// excess s, a hard cell has an all-zero stencil. The 5x5 window of cell states around fine node
// (2i, 2j) (0 absent, 1 free, 2 hard) holds everything the formula needs (GALERKIN0_*).
// Coarse planes: [D, wE, wS, wSE, wSW, s]; s (diagonal excess, = P^T s_fine because P 1 = 1 on
// every existing fine node) feeds the next Galerkin product.
inline int cell_state(__global const float* g, int x, int y, int W, int H) {
  return (x < 0 || y < 0 || x >= W || y >= H) ? 0 : (isnan(g[(size_t)y * W + x]) ? 2 : 1);
}
// Interior variant: the whole window is inside the grid.
#define cell_state_in(g, x, y, W, H) (isnan((g)[(size_t)(y) * (W) + (x)]) ? 2 : 1)

__kernel void galerkin0(__global const float* g, const int W, const int H, const float wx, const float wy,
                        __global float* stc, const int Wc, const int Hc) {
  const int j = ROW_ID();
  if (j >= Hc) return;
  const int Pc = Wc + 2;
  const size_t Nc = (size_t)Pc * (Hc + 2);
  // The stencil of a window without hard cells or border: the same formula with every state 1.
  float reg_D, reg_WE, reg_WS, reg_WSE, reg_WSW;
  {
#define cell_state(g, x, y, W, H) 1
    const int bx = 0, by = 0;
    GALERKIN0_STATES;
#undef cell_state
    GALERKIN0_LOADS;
    reg_D = GALERKIN_D;
    reg_WE = GALERKIN_WE;
    reg_WS = GALERKIN_WS;
    reg_WSE = GALERKIN_WSE;
    reg_WSW = GALERKIN_WSW;
  }
  FOR_X(i, Wc) {
    const int bx = 2 * i, by = 2 * j;
    const size_t o = GI(i, j, Pc);
    if (bx >= 2 && by >= 2 && bx + 2 < W && by + 2 < H) {
      // Most windows (78 % with 1 % hard cells) hold no hard cell: the standard stencil.
      int any_hard = 0;
      for (int b = -2; b <= 2; ++b) {
        __global const float* gr = g + (size_t)(by + b) * W + bx - 2;
        any_hard |= isnan(gr[0]) | isnan(gr[1]) | isnan(gr[2]) | isnan(gr[3]) | isnan(gr[4]);
      }
      if (!any_hard) {
        stc[o] = reg_D;
        stc[Nc + o] = reg_WE;
        stc[2 * Nc + o] = reg_WS;
        stc[3 * Nc + o] = reg_WSE;
        stc[4 * Nc + o] = reg_WSW;
        stc[5 * Nc + o] = 0.0f;
        continue;
      }
#define cell_state cell_state_in
      GALERKIN0_STATES;
#undef cell_state
      GALERKIN0_LOADS;
      stc[o] = GALERKIN_D;
      stc[Nc + o] = GALERKIN_WE;
      stc[2 * Nc + o] = GALERKIN_WS;
      stc[3 * Nc + o] = GALERKIN_WSE;
      stc[4 * Nc + o] = GALERKIN_WSW;
      stc[5 * Nc + o] = S_p0_p0 + 0.5f * (S_m1_p0 + S_p1_p0 + S_p0_m1 + S_p0_p1) +
                        0.25f * (S_m1_m1 + S_p1_m1 + S_m1_p1 + S_p1_p1);
      continue;
    }
    GALERKIN0_STATES;
    GALERKIN0_LOADS;
    stc[o] = GALERKIN_D;
    stc[Nc + o] = GALERKIN_WE;
    stc[2 * Nc + o] = GALERKIN_WS;
    stc[3 * Nc + o] = GALERKIN_WSE;
    stc[4 * Nc + o] = GALERKIN_WSW;
    stc[5 * Nc + o] = S_p0_p0 + 0.5f * (S_m1_p0 + S_p1_p0 + S_p0_m1 + S_p0_p1) +
                      0.25f * (S_m1_m1 + S_p1_m1 + S_m1_p1 + S_p1_p1);
  }
}

// Ghosted coarse stencil value, 0 outside the array (the Galerkin window reaches 2 nodes out).
inline float ld9(__global const float* st, int k, int x, int y, int W, int H) {
  return (x >= -1 && y >= -1 && x <= W && y <= H) ? st[(size_t)k * (W + 2) * (H + 2) + GI(x, y, W + 2)] : 0.0f;
}

__kernel void galerkin9(__global const float* st, const int W, const int H, __global float* stc, const int Wc,
                        const int Hc) {
  const int j = ROW_ID();
  if (j >= Hc) return;
  const int Pc = Wc + 2;
  const size_t Nc = (size_t)Pc * (Hc + 2);
  const int P = W + 2;
  const size_t N = (size_t)P * (H + 2);
  // The window reaches 2 fine nodes out; the ghost frame covers 1, so rows/columns whose window
  // stays within [-1, W] x [-1, H] need no bounds test (most of them).
  const int by = 2 * j;
  const int rows_in = (by - 2 >= -1) && (by + 2 <= H);
  FOR_X(i, Wc) {
    const int bx = 2 * i;
    const size_t o = GI(i, j, Pc);
    float d_, we_, ws_, wse_, wsw_, s_;
    if (rows_in && bx - 2 >= -1 && bx + 2 <= W) {
      __global const float* c = st + GI(bx, by, P);
#define WE(a, b) c[N + (b) * P + (a)]  // index-ok: |b| <= 2
#define WS(a, b) c[2 * N + (b) * P + (a)]  // index-ok: |b| <= 2
#define WSE(a, b) c[3 * N + (b) * P + (a)]  // index-ok: |b| <= 2
#define WSW(a, b) c[4 * N + (b) * P + (a)]  // index-ok: |b| <= 2
#define S(a, b) c[5 * N + (b) * P + (a)]  // index-ok: |b| <= 2
      GALERKIN_LOADS;
      d_ = GALERKIN_D;
      we_ = GALERKIN_WE;
      ws_ = GALERKIN_WS;
      wse_ = GALERKIN_WSE;
      wsw_ = GALERKIN_WSW;
      s_ = S_p0_p0 + 0.5f * (S_m1_p0 + S_p1_p0 + S_p0_m1 + S_p0_p1) + 0.25f * (S_m1_m1 + S_p1_m1 + S_m1_p1 + S_p1_p1);
#undef WE
#undef WS
#undef WSE
#undef WSW
#undef S
    } else {
#define WE(a, b) ld9(st, 1, bx + (a), by + (b), W, H)
#define WS(a, b) ld9(st, 2, bx + (a), by + (b), W, H)
#define WSE(a, b) ld9(st, 3, bx + (a), by + (b), W, H)
#define WSW(a, b) ld9(st, 4, bx + (a), by + (b), W, H)
#define S(a, b) ld9(st, 5, bx + (a), by + (b), W, H)
      GALERKIN_LOADS;
      d_ = GALERKIN_D;
      we_ = GALERKIN_WE;
      ws_ = GALERKIN_WS;
      wse_ = GALERKIN_WSE;
      wsw_ = GALERKIN_WSW;
      s_ = S_p0_p0 + 0.5f * (S_m1_p0 + S_p1_p0 + S_p0_m1 + S_p0_p1) + 0.25f * (S_m1_m1 + S_p1_m1 + S_m1_p1 + S_p1_p1);
#undef WE
#undef WS
#undef WSE
#undef WSW
#undef S
    }
    stc[o] = d_;
    stc[Nc + o] = we_;
    stc[2 * Nc + o] = ws_;
    stc[3 * Nc + o] = wse_;
    stc[4 * Nc + o] = wsw_;
    stc[5 * Nc + o] = s_;
  }
}

// ---------------------------------------------------------------------------------------------
// The published one-pass cascade (comparison mode): re-discretised 5-point Laplacians on every
// level (plain user-grid layout, no ghosts), constraints fused by priority while coarsening.

// Coarse node (i, j) over the fine full-weighting footprint: if any fine cell is hard, the coarse
// cell is hard with the weighted mean of the fine hard values (hard beats soft); otherwise its
// right-hand side is the weighted mean of the fine ones, renormalised by the in-grid weight at
// the border.
__kernel void fuse_restrict(__global const float* gf, __global const float* uf, const int W, const int H,
                            __global float* gc, __global float* uc, const int Wc, const int Hc) {
  const int j = ROW_ID();
  if (j >= Hc) return;
  FOR_X(i, Wc) {
    float sg = 0.0f, wg = 0.0f, sh = 0.0f, wh = 0.0f;
    for (int fy = -1; fy <= 1; ++fy) {
      const int y = 2 * j + fy;
      if (y < 0 || y >= H) continue;
      for (int fx = -1; fx <= 1; ++fx) {
        const int x = 2 * i + fx;
        if (x < 0 || x >= W) continue;
        const float w = (fx ? 0.5f : 1.0f) * (fy ? 0.5f : 1.0f);
        const size_t o = (size_t)y * W + x;
        const float gv = gf[o];
        if (isnan(gv)) {
          sh += w * uf[o];
          wh += w;
        } else {
          sg += w * gv;
          wg += w;
        }
      }
    }
    const size_t oc = (size_t)j * Wc + i;
    if (wh > 0.0f) {
      gc[oc] = NAN;
      uc[oc] = sh / wh;
    } else {
      gc[oc] = wg > 0.0f ? sg / wg : 0.0f;
      uc[oc] = 0.0f;
    }
  }
}

// u = P uc on free cells (the cascade interpolates the solution itself, not a correction).
__kernel void prolong_assign(__global float* u, __global const float* g, const int W, const int H,
                             __global const float* uc, const int Wc) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* r0 = uc + (size_t)(y >> 1) * Wc;
  __global const float* r1 = (y & 1) ? r0 + Wc : r0;
  FOR_X(x, W) {
    const int xc = x >> 1;
    const float v = (x & 1) ? 0.25f * (r0[xc] + r0[xc + 1] + r1[xc] + r1[xc + 1]) : 0.5f * (r0[xc] + r1[xc]);
    if (!isnan(g[o + x])) u[o + x] = v;
  }
}
