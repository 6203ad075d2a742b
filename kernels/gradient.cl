// SPDX-License-Identifier: Apache-2.0
// Gradient extraction and divergence on the staggered (face) grid.
//   gx(x, y) = (h(x+1, y) - h(x, y)) / cx  for x < W-1, 0 in the last column (no face there)
//   gy(x, y) = (h(x, y+1) - h(x, y)) / cy  for y < H-1, 0 in the last row
//   div(x, y) = (gx(x) - gx(x-1)) / cx + (gy(y) - gy(y-1)) / cy, faces outside the grid carry 0
// so div(extract(h)) is exactly the 5-point Neumann Laplacian the multigrid solver inverts.
// Cells in FOR_X (kernels/launch.clh: a row per work-item on PoCL, a cell per work-item on GPUs);
// no FMA contraction so the device matches a plain C++ loop bit for bit.
#pragma OPENCL FP_CONTRACT OFF
#include "launch.clh"

__kernel void extract_staggered(__global const float* h, __global float* gx, __global float* gy, const int W,
                                const int H, const float inv_cx, const float inv_cy) {
  const int y = ROW_ID();
  if (y >= H) return;
  __global const float* row = h + (size_t)y * W;
  __global const float* below = row + W;
  __global float* ox = gx + (size_t)y * W;
  __global float* oy = gy + (size_t)y * W;
  const int last_row = (y == H - 1);
  FOR_X(x, W) {
    const float c = row[x];
    ox[x] = (x + 1 < W) ? (row[x + 1] - c) * inv_cx : 0.0f;
    oy[x] = last_row ? 0.0f : (below[x] - c) * inv_cy;
  }
}

// out = scale * div(g). The solver asks for scale = -1 (it works with -Laplacian, which is SPD).
__kernel void divergence(__global const float* gx, __global const float* gy, __global float* out, const int W,
                         const int H, const float inv_cx, const float inv_cy, const float scale) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  FOR_X(x, W) {
    const float ex = (x + 1 < W) ? gx[o + x] : 0.0f;
    const float wx = (x > 0) ? gx[o + x - 1] : 0.0f;
    const float sy = (y + 1 < H) ? gy[o + x] : 0.0f;
    const float ny = (y > 0) ? gy[o - W + x] : 0.0f;
    out[o + x] = scale * ((ex - wx) * inv_cx + (sy - ny) * inv_cy);
  }
}

// The paper's central differences (h(x+1) - h(x-1)) / 2d, one-sided at the borders.
__kernel void extract_central(__global const float* h, __global float* gx, __global float* gy, const int W,
                              const int H, const float inv_cx, const float inv_cy) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  const int y0 = y > 0 ? y - 1 : y, y1 = y + 1 < H ? y + 1 : y;
  const float sy = (y1 - y0) > 0 ? inv_cy / (float)(y1 - y0) : 0.0f;
  FOR_X(x, W) {
    const int x0 = x > 0 ? x - 1 : x, x1 = x + 1 < W ? x + 1 : x;
    const float sx = (x1 - x0) > 0 ? inv_cx / (float)(x1 - x0) : 0.0f;
    gx[o + x] = (h[o + x1] - h[o + x0]) * sx;
    gy[o + x] = (h[(size_t)y1 * W + x] - h[(size_t)y0 * W + x]) * sy;
  }
}

// Central -> staggered import: the face value is the mean of the two cell-centred values beside it
// (second-order; the checkerboard mode that central differences cannot see stays lost).
__kernel void central_to_staggered(__global const float* cx_in, __global const float* cy_in, __global float* gx,
                                   __global float* gy, const int W, const int H) {
  const int y = ROW_ID();
  if (y >= H) return;
  const size_t o = (size_t)y * W;
  FOR_X(x, W) {
    gx[o + x] = (x + 1 < W) ? 0.5f * (cx_in[o + x] + cx_in[o + x + 1]) : 0.0f;
    gy[o + x] = (y + 1 < H) ? 0.5f * (cy_in[o + x] + cy_in[o + W + x]) : 0.0f;
  }
}
