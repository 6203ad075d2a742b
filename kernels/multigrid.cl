// Geometric multigrid for -Laplacian(u) = g with hard (Dirichlet) cells, on any W x H grid.
//
// Level 0 (the user's grid): 5-point operator with weights wx = 1/cx^2, wy = 1/cy^2 between in-grid
// neighbours (natural Neumann border), hard cells marked by g = NaN (their u is the fixed value).
// Coarse levels are vertex-centred: coarse node I sits on fine node 2I, n_c = n/2 + 1, so fine nodes
// past the border are simply absent (no padding memory). Their operators are Galerkin products
// P^T A P with bilinear P zeroed at hard nodes, stored in "edge form" per node as five planes
// [D, wE, wS, wSE, wSW] (diagonal and the weights -A of the forward edges; the other four come from
// the neighbours). A coarse node with D == 0 is "dead" (every fine node under it is hard) and stays 0.
//
// Layout: one work-item per row with the x-loop inside (fastest for stencils on PoCL, the fastest
// index on the contiguous axis on GPUs is the row loop's stride-1 access). Host code never waits
// between kernels of a cycle. FMA contraction off: same bits as the CPU reference loops.
#pragma OPENCL FP_CONTRACT OFF
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double acc_t;
#else
typedef float acc_t;
#endif

// ---------------------------------------------------------------------------------------------
// Level 0: 5-point operator, hard cells = NaN in g.

// Residual g - A u at (x, y) of level 0 (0 at hard cells). `cold`: free cells read as 0, i.e. the
// residual of the trivial initial guess (used as the reference norm).
inline float res0(__global const float* u, __global const float* g, int x, int y, int W, int H, float wx, float wy,
                  int cold) {
  const size_t o = (size_t)y * W + x;
  const float gv = g[o];
  if (isnan(gv)) return 0.0f;
  float sum = 0.0f, diag = 0.0f;
#define NB0(cond, off, w)                               \
  if (cond) {                                           \
    const float un = u[o + (off)];                      \
    sum += (w) * ((cold && !isnan(g[o + (off)])) ? 0.0f : un); \
    diag += (w);                                        \
  }
  NB0(x > 0, -1, wx)
  NB0(x + 1 < W, 1, wx)
  NB0(y > 0, -(long)W, wy)
  NB0(y + 1 < H, (long)W, wy)
#undef NB0
  const float uc = cold ? 0.0f : u[o];
  return gv + sum - diag * uc;
}

// Red-black Gauss-Seidel half-sweep on level 0: cells with (x + y) % 2 == colour.
__kernel void smooth_rb0(__global float* u, __global const float* g, const int W, const int H, const float wx,
                         const float wy, const int colour) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global float* row = u + o;
  __global const float* gr = g + o;
  __global const float* up = (y > 0) ? row - W : row;
  __global const float* dn = (y + 1 < H) ? row + W : row;
  const float wn = (y > 0) ? wy : 0.0f, ws = (y + 1 < H) ? wy : 0.0f;
  const float dy = wn + ws;
  int x = (y + colour) & 1;
  // The border columns take the general path; the interior loop has no bounds tests.
  if (x == 0) {
    const float gv = gr[0];
    const float wr = W > 1 ? wx : 0.0f;
    const float d = dy + wr;
    if (!isnan(gv) && d > 0.0f) row[0] = (gv + wr * (W > 1 ? row[1] : 0.0f) + wn * up[0] + ws * dn[0]) / d;
    x += 2;
  }
  const float d2 = dy + 2.0f * wx;
  for (; x < W - 1; x += 2) {
    const float gv = gr[x];
    if (!isnan(gv)) row[x] = (gv + wx * (row[x - 1] + row[x + 1]) + wn * up[x] + ws * dn[x]) / d2;
  }
  if (x == W - 1 && W > 1) {
    const float gv = gr[x];
    const float d = dy + wx;
    if (!isnan(gv) && d > 0.0f) row[x] = (gv + wx * row[x - 1] + wn * up[x] + ws * dn[x]) / d;
  }
}

// Weighted Jacobi on level 0: out = u + omega * (GS value - u).
__kernel void jacobi0(__global float* out, __global const float* u, __global const float* g, const int W, const int H,
                      const float wx, const float wy, const float omega) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  const float wn = (y > 0) ? wy : 0.0f, ws = (y + 1 < H) ? wy : 0.0f;
  for (int x = 0; x < W; ++x) {
    const float gv = g[o + x];
    const float uc = u[o + x];
    const float wl = x > 0 ? wx : 0.0f, wr = x + 1 < W ? wx : 0.0f;
    const float d = wl + wr + wn + ws;
    float v = uc;
    if (!isnan(gv) && d > 0.0f) {
      const float s = wl * (x > 0 ? u[o + x - 1] : 0.0f) + wr * (x + 1 < W ? u[o + x + 1] : 0.0f) +
                      wn * (y > 0 ? u[o + x - W] : 0.0f) + ws * (y + 1 < H ? u[o + x + W] : 0.0f);
      v = uc + omega * ((gv + s) / d - uc);
    }
    out[o + x] = v;
  }
}

// Full-weighting restriction of the level-0 residual to coarse row j (fused: the fine residual is
// never stored), and zero initial guess for the coarse correction.
__kernel void residual_restrict0(__global const float* u, __global const float* g, const int W, const int H,
                                 const float wx, const float wy, __global float* rc, __global float* ec, const int Wc,
                                 const int Hc) {
  const int j = get_global_id(0);
  if (j >= Hc) return;
  const int y0 = 2 * j - 1, y1 = 2 * j, y2 = 2 * j + 1;
  const int h0 = y0 >= 0, h1 = y1 < H, h2 = y2 < H;
#define COL(xx)                                                             \
  (((xx) < 0 || (xx) >= W) ? 0.0f                                          \
                           : ((h0 ? 0.5f * res0(u, g, xx, y0, W, H, wx, wy, 0) : 0.0f) + \
                              (h1 ? res0(u, g, xx, y1, W, H, wx, wy, 0) : 0.0f) +         \
                              (h2 ? 0.5f * res0(u, g, xx, y2, W, H, wx, wy, 0) : 0.0f)))
  float prev = 0.0f;  // column 2i-1
  for (int i = 0; i < Wc; ++i) {
    const float c0 = COL(2 * i), c1 = COL(2 * i + 1);
    rc[(size_t)j * Wc + i] = 0.5f * prev + c0 + 0.5f * c1;
    ec[(size_t)j * Wc + i] = 0.0f;
    prev = c1;
  }
#undef COL
}

// Bilinear interpolation of coarse row values at fine x (coarse node I on fine node 2I).
inline float interp_row(__global const float* r, int x) {
  const int xc = x >> 1;
  return (x & 1) ? 0.5f * (r[xc] + r[xc + 1]) : r[xc];
}

// u += P ec on free cells of level 0.
__kernel void prolong_correct0(__global float* u, __global const float* g, const int W, const int H,
                               __global const float* ec, const int Wc) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* r0 = ec + (size_t)(y >> 1) * Wc;
  __global const float* r1 = (y & 1) ? r0 + Wc : r0;
  for (int x = 0; x < W; ++x) {
    if (isnan(g[o + x])) continue;
    u[o + x] += 0.5f * (interp_row(r0, x) + interp_row(r1, x));
  }
}

// Per-row sums of squared level-0 residuals (the host adds the rows in double).
__kernel void residual_norm0(__global const float* u, __global const float* g, const int W, const int H,
                             const float wx, const float wy, const int cold, __global float* rows) {
  const int y = get_global_id(0);
  if (y >= H) return;
  acc_t s = 0;
  for (int x = 0; x < W; ++x) {
    const float r = res0(u, g, x, y, W, H, wx, wy, cold);
    s += (acc_t)r * (acc_t)r;
  }
  rows[y] = (float)s;
}

// Turns the uploaded constraint values (NaN = free) into the level-0 state: u = value - m at hard
// cells and 0 (or the warm start - m) elsewhere; g = NaN marks hard cells.
__kernel void init_level0(__global float* u, __global float* g, __global const float* warm, const int use_warm,
                          const int W, const int H, const float m) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) {
    const float c = u[o + x];
    if (isnan(c)) {
      u[o + x] = use_warm ? warm[o + x] - m : 0.0f;
    } else {
      u[o + x] = c - m;
      g[o + x] = NAN;
    }
  }
}

// g -= mean over free cells (projection onto the range of the singular pure-Neumann operator).
__kernel void shift_free(__global float* g, const int W, const int H, const float delta) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) {
    const float v = g[o + x];
    if (!isnan(v)) g[o + x] = v - delta;
  }
}

// Per-row sums (and free-cell counts) of g, for the mean in the singular case.
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
// Coarse levels: 9-point Galerkin operators in edge form, planes [D, wE, wS, wSE, wSW] of size N.

#define PLANE(st, k, N) ((st) + (size_t)(k) * (N))

// Residual r - A e at (x, y) of a coarse level.
inline float res9(__global const float* e, __global const float* r, __global const float* st, int x, int y, int W,
                  int H) {
  const size_t N = (size_t)W * H, o = (size_t)y * W + x;
  const float D = st[o];
  float s = 0.0f;
  if (x + 1 < W) s += PLANE(st, 1, N)[o] * e[o + 1];
  if (y + 1 < H) s += PLANE(st, 2, N)[o] * e[o + W];
  if (x + 1 < W && y + 1 < H) s += PLANE(st, 3, N)[o] * e[o + W + 1];
  if (x > 0 && y + 1 < H) s += PLANE(st, 4, N)[o] * e[o + W - 1];
  if (x > 0) s += PLANE(st, 1, N)[o - 1] * e[o - 1];
  if (y > 0) s += PLANE(st, 2, N)[o - W] * e[o - W];
  if (x > 0 && y > 0) s += PLANE(st, 3, N)[o - W - 1] * e[o - W - 1];
  if (x + 1 < W && y > 0) s += PLANE(st, 4, N)[o - W + 1] * e[o - W + 1];
  return r[o] + s - D * e[o];
}

// Zebra Gauss-Seidel on a 9-point level: rows of one parity in parallel (they only couple to the
// other parity), each row swept left to right (lexicographic, so x-neighbours are already new).
__kernel void smooth_zebra9(__global float* e, __global const float* r, __global const float* st, const int W,
                            const int H, const int parity) {
  const int y = 2 * (int)get_global_id(0) + parity;
  if (y >= H) return;
  const size_t N = (size_t)W * H, o = (size_t)y * W;
  __global const float* D = st + o;
  __global const float* wE = PLANE(st, 1, N) + o;
  __global const float* wS = PLANE(st, 2, N) + o;
  __global const float* wSE = PLANE(st, 3, N) + o;
  __global const float* wSW = PLANE(st, 4, N) + o;
  const int hn = y > 0, hs = y + 1 < H;
  // Rows outside the grid alias this row with zero weights.
  __global const float* wSn = hn ? wS - W : wS;
  __global const float* wSEn = hn ? wSE - W : wSE;
  __global const float* wSWn = hn ? wSW - W : wSW;
  __global float* ec = e + o;
  __global const float* en = hn ? ec - W : ec;
  __global const float* es = hs ? ec + W : ec;
  const float fn = hn ? 1.0f : 0.0f, fs = hs ? 1.0f : 0.0f;
  float west = 0.0f, wWest = 0.0f;  // e and edge weight of x-1
  for (int x = 0; x < W; ++x) {
    const int xe = x + 1 < W ? x + 1 : x, xw = x > 0 ? x - 1 : x;
    const float fe = x + 1 < W ? 1.0f : 0.0f, fw = x > 0 ? 1.0f : 0.0f;
    float s = wWest * west + fe * wE[x] * ec[xe];
    s += fs * (wS[x] * es[x] + fe * wSE[x] * es[xe] + fw * wSW[x] * es[xw]);
    s += fn * (wSn[x] * en[x] + fw * wSEn[xw] * en[xw] + fe * wSWn[xe] * en[xe]);
    const float d = D[x];
    float v = ec[x];
    if (d > 0.0f) {
      v = (r[o + x] + s) / d;
      ec[x] = v;
    }
    west = v;
    wWest = wE[x];
  }
}

// Weighted Jacobi on a 9-point level.
__kernel void jacobi9(__global float* out, __global const float* e, __global const float* r,
                      __global const float* st, const int W, const int H, const float omega) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  for (int x = 0; x < W; ++x) {
    const float d = st[o + x];
    const float ec = e[o + x];
    out[o + x] = d > 0.0f ? ec + omega * res9(e, r, st, x, y, W, H) / d : ec;
  }
}

// Restriction of the coarse-level residual (fused), zero initial coarse correction.
__kernel void residual_restrict9(__global const float* e, __global const float* r, __global const float* st,
                                 const int W, const int H, __global float* rc, __global float* ec, const int Wc,
                                 const int Hc) {
  const int j = get_global_id(0);
  if (j >= Hc) return;
  const int y0 = 2 * j - 1, y1 = 2 * j, y2 = 2 * j + 1;
  const int h0 = y0 >= 0, h1 = y1 < H, h2 = y2 < H;
#define COL(xx)                                                                \
  (((xx) < 0 || (xx) >= W) ? 0.0f                                             \
                           : ((h0 ? 0.5f * res9(e, r, st, xx, y0, W, H) : 0.0f) + \
                              (h1 ? res9(e, r, st, xx, y1, W, H) : 0.0f) +         \
                              (h2 ? 0.5f * res9(e, r, st, xx, y2, W, H) : 0.0f)))
  float prev = 0.0f;
  for (int i = 0; i < Wc; ++i) {
    const float c0 = COL(2 * i), c1 = COL(2 * i + 1);
    rc[(size_t)j * Wc + i] = 0.5f * prev + c0 + 0.5f * c1;
    ec[(size_t)j * Wc + i] = 0.0f;
    prev = c1;
  }
#undef COL
}

// e += P ec on a coarse level (dead nodes take any value: nothing couples to them).
__kernel void prolong_correct9(__global float* e, const int W, const int H, __global const float* ec, const int Wc) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* r0 = ec + (size_t)(y >> 1) * Wc;
  __global const float* r1 = (y & 1) ? r0 + Wc : r0;
  for (int x = 0; x < W; ++x) e[o + x] += 0.5f * (interp_row(r0, x) + interp_row(r1, x));
}

// Coarsest level: e = pinv(A) r with the pseudo-inverse computed on the host at set-up
// (handles the singular pure-Neumann case). One work-item per row of pinv.
__kernel void coarse_solve(__global float* e, __global const float* r, __global const float* pinv, const int n) {
  const int i = get_global_id(0);
  if (i >= n) return;
  float s = 0.0f;
  for (int j = 0; j < n; ++j) s += pinv[(size_t)i * n + j] * r[j];
  e[i] = s;
}

// ---------------------------------------------------------------------------------------------
// Galerkin coarse operators. Generated by scripts/gen_galerkin.py (do not edit by hand).
#define GALERKIN_D ( \
      0.0625f * WSE(-2, -2) \
    + 0.0625f * WS(-1, -2) \
    + 0.25f * WSE(-1, -2) \
    + 0.25f * WS(0, -2) \
    + 0.0625f * WSE(0, -2) \
    + 0.0625f * WSW(0, -2) \
    + 0.0625f * WS(1, -2) \
    + 0.25f * WSW(1, -2) \
    + 0.0625f * WSW(2, -2) \
    + 0.0625f * WE(-2, -1) \
    + 0.25f * WSE(-2, -1) \
    + 0.0625f * S(-1, -1) \
    + 0.0625f * WE(-1, -1) \
    + 0.0625f * WS(-1, -1) \
    + 0.5625f * WSE(-1, -1) \
    + 0.0625f * WSW(-1, -1) \
    + 0.25f * S(0, -1) \
    + 0.0625f * WE(0, -1) \
    + 0.25f * WS(0, -1) \
    + 0.0625f * S(1, -1) \
    + 0.0625f * WE(1, -1) \
    + 0.0625f * WS(1, -1) \
    + 0.0625f * WSE(1, -1) \
    + 0.5625f * WSW(1, -1) \
    + 0.25f * WSW(2, -1) \
    + 0.25f * WE(-2, 0) \
    + 0.0625f * WSE(-2, 0) \
    + 0.25f * S(-1, 0) \
    + 0.25f * WE(-1, 0) \
    + 0.0625f * WS(-1, 0) \
    + 0.25f * WSW(-1, 0) \
    + 1.0f * S(0, 0) \
    + 0.25f * WE(0, 0) \
    + 0.25f * WS(0, 0) \
    + 0.5625f * WSE(0, 0) \
    + 0.5625f * WSW(0, 0) \
    + 0.25f * S(1, 0) \
    + 0.25f * WE(1, 0) \
    + 0.0625f * WS(1, 0) \
    + 0.25f * WSE(1, 0) \
    + 0.0625f * WSW(2, 0) \
    + 0.0625f * WE(-2, 1) \
    + 0.0625f * S(-1, 1) \
    + 0.0625f * WE(-1, 1) \
    + 0.0625f * WS(-1, 1) \
    + 0.0625f * WSE(-1, 1) \
    + 0.0625f * WSW(-1, 1) \
    + 0.25f * S(0, 1) \
    + 0.0625f * WE(0, 1) \
    + 0.25f * WS(0, 1) \
    + 0.25f * WSE(0, 1) \
    + 0.25f * WSW(0, 1) \
    + 0.0625f * S(1, 1) \
    + 0.0625f * WE(1, 1) \
    + 0.0625f * WS(1, 1) \
    + 0.0625f * WSE(1, 1) \
    + 0.0625f * WSW(1, 1) \
  )
#define GALERKIN_WE ( \
      -0.0625f * WSE(0, -2) \
    + -0.0625f * WS(1, -2) \
    + -0.0625f * WSW(2, -2) \
    + 0.0625f * WE(0, -1) \
    + -0.0625f * S(1, -1) \
    + 0.0625f * WE(1, -1) \
    + -0.0625f * WS(1, -1) \
    + 0.1875f * WSE(1, -1) \
    + 0.1875f * WSW(1, -1) \
    + 0.25f * WE(0, 0) \
    + 0.1875f * WSE(0, 0) \
    + -0.25f * S(1, 0) \
    + 0.25f * WE(1, 0) \
    + -0.0625f * WS(1, 0) \
    + 0.1875f * WSW(2, 0) \
    + 0.0625f * WE(0, 1) \
    + -0.0625f * S(1, 1) \
    + 0.0625f * WE(1, 1) \
    + -0.0625f * WS(1, 1) \
    + -0.0625f * WSE(1, 1) \
    + -0.0625f * WSW(1, 1) \
  )
#define GALERKIN_WS ( \
      -0.0625f * WSE(-2, 0) \
    + 0.0625f * WS(-1, 0) \
    + 0.25f * WS(0, 0) \
    + 0.1875f * WSE(0, 0) \
    + 0.1875f * WSW(0, 0) \
    + 0.0625f * WS(1, 0) \
    + -0.0625f * WSW(2, 0) \
    + -0.0625f * WE(-2, 1) \
    + -0.0625f * S(-1, 1) \
    + -0.0625f * WE(-1, 1) \
    + 0.0625f * WS(-1, 1) \
    + 0.1875f * WSE(-1, 1) \
    + -0.0625f * WSW(-1, 1) \
    + -0.25f * S(0, 1) \
    + -0.0625f * WE(0, 1) \
    + 0.25f * WS(0, 1) \
    + -0.0625f * S(1, 1) \
    + -0.0625f * WE(1, 1) \
    + 0.0625f * WS(1, 1) \
    + -0.0625f * WSE(1, 1) \
    + 0.1875f * WSW(1, 1) \
  )
#define GALERKIN_WSE ( \
      0.1875f * WSE(0, 0) \
    + 0.0625f * WS(1, 0) \
    + 0.25f * WSE(1, 0) \
    + -0.0625f * WSW(2, 0) \
    + 0.0625f * WE(0, 1) \
    + 0.25f * WSE(0, 1) \
    + -0.0625f * S(1, 1) \
    + 0.0625f * WE(1, 1) \
    + 0.0625f * WS(1, 1) \
    + 0.1875f * WSE(1, 1) \
    + -0.0625f * WSW(1, 1) \
  )
#define GALERKIN_WSW ( \
      -0.0625f * WSE(-2, 0) \
    + 0.0625f * WS(-1, 0) \
    + 0.25f * WSW(-1, 0) \
    + 0.1875f * WSW(0, 0) \
    + 0.0625f * WE(-2, 1) \
    + -0.0625f * S(-1, 1) \
    + 0.0625f * WE(-1, 1) \
    + 0.0625f * WS(-1, 1) \
    + -0.0625f * WSE(-1, 1) \
    + 0.1875f * WSW(-1, 1) \
    + 0.25f * WSW(0, 1) \
  )

// Fine stencil accessors in edge form, relative to fine node (2i, 2j); absent nodes give 0.
// Level 0 applies D A D (hard rows/columns removed): an edge to a hard cell becomes diagonal
// excess s, a hard cell has an all-zero stencil.
inline int free0(__global const float* g, int x, int y, int W, int H) {
  return x >= 0 && y >= 0 && x < W && y < H && !isnan(g[(size_t)y * W + x]);
}
inline int hard0(__global const float* g, int x, int y, int W, int H) {
  return x >= 0 && y >= 0 && x < W && y < H && isnan(g[(size_t)y * W + x]);
}
inline float we0(__global const float* g, int x, int y, int W, int H, float wx) {
  return (free0(g, x, y, W, H) && free0(g, x + 1, y, W, H)) ? wx : 0.0f;
}
inline float ws0(__global const float* g, int x, int y, int W, int H, float wy) {
  return (free0(g, x, y, W, H) && free0(g, x, y + 1, W, H)) ? wy : 0.0f;
}
inline float s0(__global const float* g, int x, int y, int W, int H, float wx, float wy) {
  if (!free0(g, x, y, W, H)) return 0.0f;
  return wx * (float)(hard0(g, x - 1, y, W, H) + hard0(g, x + 1, y, W, H)) +
         wy * (float)(hard0(g, x, y - 1, W, H) + hard0(g, x, y + 1, W, H));
}

__kernel void galerkin0(__global const float* g, const int W, const int H, const float wx, const float wy,
                        __global float* stc, const int Wc, const int Hc) {
  const int j = get_global_id(0);
  if (j >= Hc) return;
  const size_t Nc = (size_t)Wc * Hc;
  for (int i = 0; i < Wc; ++i) {
    const int bx = 2 * i, by = 2 * j;
#define WE(a, b) we0(g, bx + (a), by + (b), W, H, wx)
#define WS(a, b) ws0(g, bx + (a), by + (b), W, H, wy)
#define WSE(a, b) 0.0f
#define WSW(a, b) 0.0f
#define S(a, b) s0(g, bx + (a), by + (b), W, H, wx, wy)
    const size_t o = (size_t)j * Wc + i;
    stc[o] = GALERKIN_D;
    PLANE(stc, 1, Nc)[o] = GALERKIN_WE;
    PLANE(stc, 2, Nc)[o] = GALERKIN_WS;
    PLANE(stc, 3, Nc)[o] = GALERKIN_WSE;
    PLANE(stc, 4, Nc)[o] = GALERKIN_WSW;
#undef WE
#undef WS
#undef WSE
#undef WSW
#undef S
  }
}

inline float ld9(__global const float* st, int k, int x, int y, int W, int H) {
  return (x >= 0 && y >= 0 && x < W && y < H) ? st[(size_t)k * W * H + (size_t)y * W + x] : 0.0f;
}
// Diagonal excess s = D - (sum of the 8 edge weights) of a stored 9-point stencil.
inline float s9(__global const float* st, int x, int y, int W, int H) {
  if (x < 0 || y < 0 || x >= W || y >= H) return 0.0f;
  return ld9(st, 0, x, y, W, H) - (ld9(st, 1, x, y, W, H) + ld9(st, 2, x, y, W, H) + ld9(st, 3, x, y, W, H) +
                                   ld9(st, 4, x, y, W, H) + ld9(st, 1, x - 1, y, W, H) + ld9(st, 2, x, y - 1, W, H) +
                                   ld9(st, 3, x - 1, y - 1, W, H) + ld9(st, 4, x + 1, y - 1, W, H));
}

__kernel void galerkin9(__global const float* st, const int W, const int H, __global float* stc, const int Wc,
                        const int Hc) {
  const int j = get_global_id(0);
  if (j >= Hc) return;
  const size_t Nc = (size_t)Wc * Hc;
  for (int i = 0; i < Wc; ++i) {
    const int bx = 2 * i, by = 2 * j;
#define WE(a, b) ld9(st, 1, bx + (a), by + (b), W, H)
#define WS(a, b) ld9(st, 2, bx + (a), by + (b), W, H)
#define WSE(a, b) ld9(st, 3, bx + (a), by + (b), W, H)
#define WSW(a, b) ld9(st, 4, bx + (a), by + (b), W, H)
#define S(a, b) s9(st, bx + (a), by + (b), W, H)
    const size_t o = (size_t)j * Wc + i;
    stc[o] = GALERKIN_D;
    PLANE(stc, 1, Nc)[o] = GALERKIN_WE;
    PLANE(stc, 2, Nc)[o] = GALERKIN_WS;
    PLANE(stc, 3, Nc)[o] = GALERKIN_WSE;
    PLANE(stc, 4, Nc)[o] = GALERKIN_WSW;
#undef WE
#undef WS
#undef WSE
#undef WSW
#undef S
  }
}

// ---------------------------------------------------------------------------------------------
// The published one-pass cascade (comparison mode): re-discretised 5-point Laplacians on every
// level, constraints fused by priority while coarsening.

// Coarse node (i, j) over the fine full-weighting footprint: if any fine cell is hard, the coarse
// cell is hard with the weighted mean of the fine hard values (hard beats soft); otherwise its
// right-hand side is the weighted mean of the fine ones, renormalised by the in-grid weight at
// the border.
__kernel void fuse_restrict(__global const float* gf, __global const float* uf, const int W, const int H,
                            __global float* gc, __global float* uc, const int Wc, const int Hc) {
  const int j = get_global_id(0);
  if (j >= Hc) return;
  for (int i = 0; i < Wc; ++i) {
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
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  __global const float* r0 = uc + (size_t)(y >> 1) * Wc;
  __global const float* r1 = (y & 1) ? r0 + Wc : r0;
  for (int x = 0; x < W; ++x)
    if (!isnan(g[o + x])) u[o + x] = 0.5f * (interp_row(r0, x) + interp_row(r1, x));
}
