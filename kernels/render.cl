// SPDX-License-Identifier: Apache-2.0
// Preview pictures, one work-item per row of a strip (fastest stencil layout on PoCL): hillshade
// (gdaldem's standard, multidirectional, combined or Igor shading), colour relief, slope as grey,
// shaded relief. Host reference: host/src/render/render.cpp (double precision; the two agree
// within one level per channel). Output: nch interleaved bytes per pixel; grey modes write grey
// (+ alpha when nch == 2), colour modes RGB (+ alpha when nch == 4). Alpha is 0 where gdaldem
// writes nodata.
#pragma OPENCL FP_CONTRACT OFF
#include "render_window.clh"
#include "launch.clh"
#include "render_ramp.clh"

#define MODE_HILLSHADE 0
#define MODE_RELIEF 1
#define MODE_SLOPE 2
#define MODE_SHADED_RELIEF 3

// The picture of one pixel from its window `v` (ok = 0 where gdaldem writes nodata), c = centre.
__attribute__((always_inline)) inline void render_pixel(const int mode, const int shading, const int ok, const float* v, const float c,
                         const float* p, __global const float* ramp_z, __global const uchar* ramp_rgb,
                         const int nramp, const uint nodata_rgb, const int nch, __global uchar* o) {
  if (mode == MODE_HILLSHADE || mode == MODE_SLOPE) {
    uchar g = 0;
    if (ok && mode == MODE_HILLSHADE) g = rw_byte(rw_shade(v, shading, p));
    if (ok && mode == MODE_SLOPE) {
      const float s = rw_slope(v, p, 0);
      g = rw_byte(255.0f * (1.0f - fmin(s, p[P_SLOPE_MAX]) / p[P_SLOPE_MAX]));
    }
    o[0] = g;
    if (nch == 2) o[1] = ok ? 255 : 0;
    return;
  }
  uchar rgb[3];
  ramp_color(c, ramp_z, ramp_rgb, nramp, nodata_rgb, rgb);
  if (mode == MODE_SHADED_RELIEF && ok) {
    const float shade = (float)rw_byte(rw_shade(v, shading, p));
    const float k = (0.3f + 0.7f * shade / 255.0f) / (0.3f + 0.7f * p[P_FLAT] / 255.0f);
    for (int ch = 0; ch < 3; ++ch) rgb[ch] = rw_byte((float)rgb[ch] * k);
  }
  o[0] = rgb[0], o[1] = rgb[1], o[2] = rgb[2];
  if (nch == 4) o[3] = isnan(c) ? 0 : 255;
}

// The grey picture of a cell whose 3x3 window `v` holds no nodata, shading fixed at compile time
// after inlining (the loops below instantiate it per shading), so the x-loop has no branch.
#define GREY_PASS(SHADING, NCH)                                              \
  for (int x = 1; x < w - 1; ++x) {                                          \
    float v[9];                                                              \
    any_nan |= rw_inner(up, md, dn, x, v);                                   \
    row[(size_t)x * NCH] = rw_byte(rw_shade(v, SHADING, pp));               \
    if (NCH == 2) row[(size_t)x * NCH + 1] = 255;                           \
  }

// z holds grid rows [r0, r0 + strip rows); this launch writes picture rows [y0, y0 + rows) into
// `out` (row 0 of out = grid row y0). Inner cells read their 3x3 window and take the general
// window (edges, nodata) only when a value is NaN.
__kernel void render_rows(__global const float* z, const int w, const int h, const int r0, const int y0,
                          const int rows, const int mode, const int shading, const int edges,
                          __global const float* p, __global const float* ramp_z, __global const uchar* ramp_rgb,
                          const int nramp, const uint nodata_rgb, const int nch, __global uchar* out) {
  const int j = ROW_ID();
  if (j >= rows) return;
  const int y = y0 + j;
  // The parameters in private memory: the picture's byte stores may alias any __global pointer
  // (char aliases everything), which made every pixel reload them from p.
  float pp[P_COUNT];
  for (int k = 0; k < P_COUNT; ++k) pp[k] = p[k];
  // Shaded relief is not a gdaldem product: its shade always computes the edges, so only nodata
  // cells are transparent.
  const int win_edges = mode == MODE_SHADED_RELIEF ? 1 : edges;
  const int windowed = mode != MODE_RELIEF;
  // 64-bit offsets: nch * cells passes 2^31 from 537 M cells.
  __global uchar* row = out + (size_t)j * w * nch;
  float v[9];
  const int inner = y > 0 && y < h - 1 && w > 2;
#ifdef TERRACL_WIDE
  // One pixel per work-item: the same window and the same NaN test, so both shapes give the
  // same bytes.
  const int x = get_global_id(0);
  if (x >= w) return;
  if (inner && x > 0 && x < w - 1) {
    __global const float* up = z + (size_t)(y - 1 - r0) * w + x;
    __global const float* md = up + w;
    __global const float* dn = md + w;
    v[0] = up[-1], v[1] = up[0], v[2] = up[1], v[3] = md[-1], v[4] = md[0], v[5] = md[1];
    v[6] = dn[-1], v[7] = dn[0], v[8] = dn[1];
    const float b1 = v[4];
    int ok = 1;
    if (isnan(v[0] + v[3] + v[6] + v[1] + v[4] + v[7] + v[2] + v[5] + v[8]))
      ok = windowed && rw_window(z, w, h, r0, x, y, win_edges, v);
    render_pixel(mode, shading, ok && windowed, v, b1, pp, ramp_z, ramp_rgb, nramp, nodata_rgb, nch,
                 row + (size_t)x * nch);
    return;
  }
  {
    const float c = rw_z(z, w, r0, x, y);
    const int ok = windowed && rw_window(z, w, h, r0, x, y, win_edges, v);
    render_pixel(mode, shading, ok, v, c, pp, ramp_z, ramp_rgb, nramp, nodata_rgb, nch, row + (size_t)x * nch);
  }
#else
  if (inner) {
    __global const float* up = z + (size_t)(y - 1 - r0) * w;
    __global const float* md = up + w;
    __global const float* dn = md + w;
    // Hillshade: a branch-free pass over every inner cell as if no window held nodata (the
    // compiler vectorises it), then the cells whose window does hold nodata again, one by one.
    int any_nan = 0, fast = 1;
    if (mode == MODE_HILLSHADE && shading == SHADE_STANDARD && nch == 1) {
      GREY_PASS(SHADE_STANDARD, 1)
    } else if (mode == MODE_HILLSHADE && shading == SHADE_STANDARD && nch == 2) {
      GREY_PASS(SHADE_STANDARD, 2)
    } else if (mode == MODE_HILLSHADE && shading == SHADE_MULTIDIRECTIONAL && nch == 1) {
      GREY_PASS(SHADE_MULTIDIRECTIONAL, 1)
    } else if (mode == MODE_HILLSHADE && shading == SHADE_MULTIDIRECTIONAL && nch == 2) {
      GREY_PASS(SHADE_MULTIDIRECTIONAL, 2)
    } else {
      fast = 0;
    }
    if (fast) {
      for (int x = 1; any_nan && x < w - 1; ++x) {
        const float sum =
            up[x - 1] + md[x - 1] + dn[x - 1] + up[x] + md[x] + dn[x] + up[x + 1] + md[x + 1] + dn[x + 1];
        if (!isnan(sum)) continue;
        const int ok = rw_window(z, w, h, r0, x, y, win_edges, v);
        render_pixel(mode, shading, ok, v, md[x], pp, ramp_z, ramp_rgb, nramp, nodata_rgb, nch,
                     row + (size_t)x * nch);
      }
    } else {
      // Other pictures slide the window along the row (three new loads per pixel).
      float a0 = up[0], a1 = md[0], a2 = dn[0], b0 = up[1], b1 = md[1], b2 = dn[1];
      for (int x = 1; x < w - 1; ++x) {
        const float c0 = up[x + 1], c1 = md[x + 1], c2 = dn[x + 1];
        v[0] = a0, v[1] = b0, v[2] = c0, v[3] = a1, v[4] = b1, v[5] = c1, v[6] = a2, v[7] = b2, v[8] = c2;
        int ok = 1;
        if (isnan(a0 + a1 + a2 + b0 + b1 + b2 + c0 + c1 + c2)) ok = windowed && rw_window(z, w, h, r0, x, y, win_edges, v);
        render_pixel(mode, shading, ok && windowed, v, b1, pp, ramp_z, ramp_rgb, nramp, nodata_rgb, nch,
                     row + (size_t)x * nch);
        a0 = b0, a1 = b1, a2 = b2, b0 = c0, b1 = c1, b2 = c2;
      }
    }
  }
  // The general path: every cell of the first and last rows, the two end cells of inner rows.
  for (int x = 0; x < w; x = (inner && x == 0) ? w - 1 : x + 1) {
    const float c = rw_z(z, w, r0, x, y);
    const int ok = windowed && rw_window(z, w, h, r0, x, y, win_edges, v);
    render_pixel(mode, shading, ok, v, c, pp, ramp_z, ramp_rgb, nramp, nodata_rgb, nch, row + (size_t)x * nch);
  }
#endif
}
