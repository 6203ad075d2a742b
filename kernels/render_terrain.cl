// SPDX-License-Identifier: Apache-2.0
// gdaldem's value rasters, one work-item per row of a strip: slope (degrees or percent), aspect,
// TRI (Riley or Wilson), TPI, roughness, as float32 with NaN where gdaldem writes nodata. Each is
// gdaldem's formula in the same operation order (host reference: host/src/render/terrain.cpp).
// Profile and tangential curvature: GRASS r.slope.aspect's (host: render_window.hpp curvature()).
#pragma OPENCL FP_CONTRACT OFF
#include "render_window.clh"
#include "launch.clh"

#define VAL_SLOPE 0
#define VAL_ASPECT 1
#define VAL_TRI 2
#define VAL_TPI 3
#define VAL_ROUGHNESS 4
#define VAL_PCURV 5
#define VAL_TCURV 6

#define FLAG_PERCENT 1
#define FLAG_WILSON 2
#define FLAG_TRIGONOMETRIC 4
#define FLAG_ZERO_FOR_FLAT 8

// GRASS's signs: its derivatives are minus those along east and north (see the host reference).
inline float curvature(const float* v, const float* p, const int profile) {
  const float cx = 1.0f / p[P_INV_EW], cy = -1.0f / p[P_INV_NS];
  const float kz = p[P_ZS] * (p[P_ALG] != 0.0f ? 2.0f : 8.0f);  // z_factor / scale
  const float gx = ((v[0] + v[3] + v[3] + v[6]) - (v[2] + v[5] + v[5] + v[8])) * kz / (8.0f * cx);
  const float gy = ((v[6] + v[7] + v[7] + v[8]) - (v[0] + v[1] + v[1] + v[2])) * kz / (8.0f * cy);
  const float s4 = v[0] + v[2] + v[6] + v[8] - 8.0f * v[4];
  const float s5 = 4.0f * (v[3] + v[5]) - 2.0f * (v[1] + v[7]);
  const float s6 = 4.0f * (v[1] + v[7]) - 2.0f * (v[3] + v[5]);
  const float s3 = v[6] - v[8] + v[2] - v[0];
  const float dxx = -(s4 + s5) * kz / (6.0f * cx * cx), dyy = -(s4 + s6) * kz / (6.0f * cy * cy);
  const float dxy = -s3 * kz / (4.0f * cx * cy);
  const float g2 = gx * gx + gy * gy;
  if (sqrt(g2) <= 0.001f) return 0.0f;
  const float q = g2 + 1.0f, cross = 2.0f * dxy * gx * gy;
  return profile ? (dxx * gx * gx + cross + dyy * gy * gy) / (g2 * q * sqrt(q))
                 : (dxx * gy * gy - cross + dyy * gx * gx) / (g2 * sqrt(q));
}

inline float terrain_value(const float* v, const int mode, const int flags, const float* p) {
  if (mode == VAL_SLOPE) return rw_slope(v, p, flags & FLAG_PERCENT);
  if (mode == VAL_ASPECT) {
    // gdaldem: atan2(dy, -dx) on Horn's raw sums; scaled by the cell sizes here (the same angle
    // on square cells, the true aspect on rectangular ones).
    const float hx = rw_gx(v, p), hy = rw_gy(v, p);
    if (hx == 0.0f && hy == 0.0f) return (flags & FLAG_ZERO_FOR_FLAT) ? 0.0f : NAN;
    float a = degrees(atan2(hy * -p[P_INV_NS], hx * p[P_INV_EW]));
    if (!(flags & FLAG_TRIGONOMETRIC))
      a = a > 90.0f ? 450.0f - a : 90.0f - a;
    else if (a < 0.0f)
      a += 360.0f;
    return a == 360.0f ? 0.0f : a;
  }
  if (mode == VAL_TRI) {
    if (flags & FLAG_WILSON)
      return (fabs(v[0] - v[4]) + fabs(v[1] - v[4]) + fabs(v[2] - v[4]) + fabs(v[3] - v[4]) + fabs(v[5] - v[4]) +
              fabs(v[6] - v[4]) + fabs(v[7] - v[4]) + fabs(v[8] - v[4])) *
             0.125f;
    float s = 0.0f;
    for (int k = 0; k < 9; ++k) s += (v[k] - v[4]) * (v[k] - v[4]);
    return sqrt(s);
  }
  if (mode == VAL_TPI) return v[4] - ((v[0] + v[1] + v[2] + v[3] + v[5] + v[6] + v[7] + v[8]) * 0.125f);
  if (mode == VAL_PCURV || mode == VAL_TCURV) return curvature(v, p, mode == VAL_PCURV);
  float lo = v[0], hi = v[0];
  for (int k = 1; k < 9; ++k) lo = fmin(lo, v[k]), hi = fmax(hi, v[k]);
  return hi - lo;
}

// The values of a row's inner cells as if no window held nodata, the mode fixed at compile time
// after inlining (one loop per mode below), so the x-loop has no branch on it and vectorises.
#define VALUE_PASS(MODE)                                                                 \
  for (int x = 1; x < w - 1; ++x) {                                                      \
    float v[9];                                                                          \
    any_nan |= rw_inner(up, md, dn, x, v);                                               \
    o[x] = terrain_value(v, MODE, flags, pp);                                            \
  }

__kernel void terrain_rows(__global const float* z, const int w, const int h, const int r0, const int y0,
                           const int rows, const int mode, const int flags, const int edges,
                           __global const float* p, __global float* out) {
  const int j = ROW_ID();
  if (j >= rows) return;
  const int y = y0 + j;
  float pp[P_COUNT];  // private: the output stores may not alias them
  for (int k = 0; k < P_COUNT; ++k) pp[k] = p[k];
  __global float* o = out + (size_t)j * w;
#ifndef TERRACL_WIDE
  // Inner rows: a branch-free pass over the inner cells, then the cells whose window holds nodata
  // again through the general window (the same values as the general path: same window, same
  // formula), then the two end cells.
  if (y > 0 && y < h - 1 && w > 2) {
    __global const float* up = z + (size_t)(y - 1 - r0) * w;
    __global const float* md = up + w;
    __global const float* dn = md + w;
    int any_nan = 0;
    if (mode == VAL_SLOPE) {
      VALUE_PASS(VAL_SLOPE)
    } else if (mode == VAL_ASPECT) {
      VALUE_PASS(VAL_ASPECT)
    } else if (mode == VAL_TRI) {
      VALUE_PASS(VAL_TRI)
    } else if (mode == VAL_TPI) {
      VALUE_PASS(VAL_TPI)
    } else if (mode == VAL_PCURV) {
      VALUE_PASS(VAL_PCURV)
    } else if (mode == VAL_TCURV) {
      VALUE_PASS(VAL_TCURV)
    } else {
      VALUE_PASS(VAL_ROUGHNESS)
    }
    for (int x = 1; any_nan && x < w - 1; ++x) {
      const float sum = up[x - 1] + md[x - 1] + dn[x - 1] + up[x] + md[x] + dn[x] + up[x + 1] + md[x + 1] + dn[x + 1];
      if (!isnan(sum)) continue;
      float v[9];
      o[x] = rw_window(z, w, h, r0, x, y, edges, v) ? terrain_value(v, mode, flags, pp) : NAN;
    }
    for (int x = 0; x < w; x += w - 1) {
      float v[9];
      o[x] = rw_window(z, w, h, r0, x, y, edges, v) ? terrain_value(v, mode, flags, pp) : NAN;
    }
    return;
  }
#endif
  FOR_X(x, w) {
    float v[9];
    o[x] = rw_window(z, w, h, r0, x, y, edges, v) ? terrain_value(v, mode, flags, pp) : NAN;
  }
}
