// SPDX-License-Identifier: Apache-2.0
// The coarse part of a multigrid cycle in one launch: from a level that fits one
// work-group down to the coarsest and back (zebra smoothing, residual restriction, the coarsest
// pseudo-inverse, prolongation, zebra smoothing), with the corrections of every level in local memory and
// barriers between the stages, instead of ~10 launches per level per cycle. On a GPU those coarse
// launches do almost no work and cost ~18 us each in launch and sync.
//
// Same arithmetic, in the same order, as smooth9 (xstep 1, i.e. the zebra order the host uses
// below kFourColourCells), residual_restrict9, prolong_correct9 and coarse_solve in
// multigrid.cl: the result is the same bits as the multi-launch path (tests/test_reconstruct.cpp
// MultigridFused*). Layout as there: ghosted arrays of pitch W + 2 (zero ghost frame).
//
// One work-group. The corrections e of every level live in local memory (`lm`, ghost frames zero);
// the right-hand sides r stay in global memory (read once per node and sweep; in local memory
// too, 1025^2's 65^2..5^2 levels would need 50 KB, past an H100's 48 KB): level `first` reads its
// r from its own level buffer `rg`, the levels below write and read theirs in the scratch `rs`.
// `meta` has 4 ints per fused level k (0 = the fused top level): W, H, offset of its five stencil
// planes [D, wE, wS, wSE, wSW] in `st` (floats, plane size (W+2)(H+2)), offset of its e in `lm` and
// of its r in `rs`. The cycle starts at level `first` (its e comes from and goes back to `eg`) and
// the coarsest is level `last`.
#pragma OPENCL FP_CONTRACT OFF
#include "stencil9.clh"

// int indices throughout: the fused levels have at most kFusedMaxCells = 72^2 nodes (multigrid.cpp).
#define GI(x, y, P) ((y) + 1) * (P) + (x) + 1
// Deep enough for any grid: a level of 2^31 cells has fewer than 32 levels below it.
#define MAX_LEVELS 32

// r - A e at ghosted index o, the same sum in the same order as res9 (multigrid.cl): both expand
// kernels/stencil9.clh.
inline float res9l(__local const float* e, __global const float* r, __global const float* st, int o, int P, int N) {
  STENCIL9_RESIDUAL(e, r, st, o, P, N)
}

// Zebra Gauss-Seidel: rows y % 2 == 0, then y % 2 == 1, each row swept left to right by one
// work-item (rows of one parity only couple to the other parity).
void smooth_l(__local float* e, __global const float* r, __global const float* st, int W, int H, int sweeps) {
  const int P = W + 2, N = P * (H + 2);  // index-ok: fused levels have <= 72^2 nodes
  const int lid = get_local_id(0), lsz = get_local_size(0);
  for (int s = 0; s < sweeps; ++s)
    for (int py = 0; py < 2; ++py) {
      for (int y = 2 * lid + py; y < H; y += 2 * lsz)
        for (int x = 0; x < W; ++x) {
          const int o = GI(x, y, P);
          STENCIL9_SMOOTH_NODE(e, st, o, res9l(e, r, st, o, P, N))
        }
      barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
    }
}

// Full-weighting restriction of the residual of fine level (e, r; W x H) to rc, and ec = 0.
void restrict_l(__local const float* e, __global const float* r, __global const float* st, int W, int H,
                __global float* rc, __local float* ec, int Wc, int Hc) {
  const int P = W + 2, Pc = Wc + 2, N = P * (H + 2);  // index-ok: fused levels have <= 72^2 nodes
  for (int k = get_local_id(0); k < Wc * Hc; k += get_local_size(0)) {
    const int i = k % Wc, j = k / Wc;
    const float a0 = 2 * j - 1 >= 0 ? 0.5f : 0.0f, a1 = 2 * j < H ? 1.0f : 0.0f, a2 = 2 * j + 1 < H ? 0.5f : 0.0f;
    const int y0 = max(2 * j - 1, 0), y1 = min(2 * j, H - 1), y2 = min(2 * j + 1, H - 1);
#define COL(xx)                                                         \
  ((a0 != 0.0f ? a0 * res9l(e, r, st, GI(xx, y0, P), P, N) : 0.0f) +   \
   (a1 != 0.0f ? res9l(e, r, st, GI(xx, y1, P), P, N) : 0.0f) +        \
   (a2 != 0.0f ? a2 * res9l(e, r, st, GI(xx, y2, P), P, N) : 0.0f))
    const float prev = (i > 0 && 2 * i - 1 < W) ? COL(2 * i - 1) : 0.0f;
    const float c0 = 2 * i < W ? COL(2 * i) : 0.0f;
    const float c1 = 2 * i + 1 < W ? COL(2 * i + 1) : 0.0f;
#undef COL
    rc[GI(i, j, Pc)] = 0.5f * prev + c0 + 0.5f * c1;
    ec[GI(i, j, Pc)] = 0.0f;
  }
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
}

// e += P ec (bilinear) on every node of the fine level.
void prolong_l(__local float* e, int W, int H, __local const float* ec, int Wc) {
  const int P = W + 2, Pc = Wc + 2;
  for (int k = get_local_id(0); k < W * H; k += get_local_size(0)) {
    const int x = k % W, y = k / W;
    __local const float* r0 = ec + GI(0, y >> 1, Pc);
    __local const float* r1 = (y & 1) ? r0 + Pc : r0;
    const int xc = x >> 1;
    e[GI(x, y, P)] += (x & 1) ? 0.25f * (r0[xc] + r0[xc + 1] + r1[xc] + r1[xc + 1]) : 0.5f * (r0[xc] + r1[xc]);
  }
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
}

// e = pinv r on the coarsest level (n = W * H nodes).
void coarse_l(__local float* e, __global const float* r, __global const float* pinv, int W, int H) {
  const int P = W + 2, n = W * H;  // index-ok: fused levels have <= 72^2 nodes
  for (int i = get_local_id(0); i < n; i += get_local_size(0)) {
    float s = 0.0f;
    for (int j = 0; j < n; ++j) s += pinv[i * n + j] * r[GI(j % W, j / W, P)];
    e[GI(i % W, i / W, P)] = s;
  }
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
}

__kernel void coarse_cycle(__global float* eg, __global const float* rg, __global const float* st,
                           __global const float* pinv, __global const int* meta, const int first, const int last,
                           const int pre, const int post, const int gamma, __local float* lm, const int lm_floats,
                           __global float* rs) {
  const int lid = get_local_id(0), lsz = get_local_size(0);
  // Ghost frames (and everything else) start at zero; then the top level's e comes in.
  for (int i = lid; i < lm_floats; i += lsz) lm[i] = 0.0f;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  const int n0 = (meta[4 * first] + 2) * (meta[4 * first + 1] + 2);
  __local float* e0 = lm + meta[4 * first + 3];
  for (int i = lid; i < n0; i += lsz) e0[i] = eg[i];
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);

  // The host's recursive cycle(l, gamma) unrolled: visits[k] counts the coarse cycles level k has
  // started (gamma of them when k + 2 <= last, else one). Every work-item takes the same path.
  int visits[MAX_LEVELS];
  int k = first;
  bool entering = true;
  for (;;) {
#define LEVEL(k) meta[4 * (k)], meta[4 * (k) + 1]
#define E(k) (lm + meta[4 * (k) + 3])
#define R(k) ((k) == first ? rg : (__global const float*)(rs + meta[4 * (k) + 3]))
#define ST(k) (st + meta[4 * (k) + 2])
    if (entering) {
      if (k == last) {
        coarse_l(E(k), R(k), pinv, LEVEL(k));
        entering = false;
      } else {
        smooth_l(E(k), R(k), ST(k), LEVEL(k), pre);
        restrict_l(E(k), R(k), ST(k), LEVEL(k), rs + meta[4 * (k + 1) + 3], E(k + 1), LEVEL(k + 1));
        visits[k] = 1;
        ++k;
      }
    } else {  // cycle(k) is done: back in level k - 1's cycle
      if (k == first) break;
      const int p = k - 1;
      if (visits[p] < (gamma > 1 && p + 2 <= last ? gamma : 1)) {
        ++visits[p];
        entering = true;
      } else {
        prolong_l(E(p), LEVEL(p), E(k), meta[4 * k]);
        smooth_l(E(p), R(p), ST(p), LEVEL(p), post);
        k = p;
      }
    }
#undef LEVEL
#undef E
#undef R
#undef ST
  }
  for (int i = lid; i < n0; i += lsz) eg[i] = e0[i];
}
