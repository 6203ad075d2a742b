// SPDX-License-Identifier: Apache-2.0
// Perspective picture of a heightfield (render --mode perspective), one work-item per pixel: the
// pixel's ray is clipped to the grid's box, marched against the bilinear surface in steps of half a
// cell, the first crossing refined by bisection, shaded by the sun (Lambert + ambient on the
// interpolated vertex normals, a march toward the sun for cast shadows), coloured by the ramp at
// the hit's elevation or by the natural material (render_material.clh), and hazed toward the sky
// with distance. A water plane, where the ray meets it first, shows the terrain under it through
// Beer-Lambert absorption toward a deep colour, the sky by Fresnel and the sun's glint. Nodata quads
// are holes. Host reference, step for step in double: host/src/render/view.cpp and view_look.cpp
// (slots: view_slots()).
#pragma OPENCL FP_CONTRACT OFF
#include "render_window.clh"
#include "render_ramp.clh"
#include "render_material.clh"

#define V_EYE 0
#define V_FWD 3
#define V_RIGHT 6
#define V_UP 9
#define V_SUN 12
#define V_CX 15
#define V_CY 16
#define V_ZF 17
#define V_ZLO 18
#define V_ZHI 19
#define V_AMBIENT 20
#define V_DIFFUSE 21
#define V_HAZE 22
#define V_HAZE_NEAR 23
#define V_HAZE_SCALE 24
#define V_SHADOWS 25
#define V_MATERIAL 26
#define V_WATER 27
#define V_WATER_Z 28
#define V_CLARITY 29
#define V_BASE 30
#define V_INV_RANGE 31
#define V_SNOW_E 32
#define V_LAMBDA 33
#define V_INV_ZF 34
#define V_DEEP 35
// view_internal.hpp's kWaterF0, kGlintPower, kGlintGain, kClarityG, kClarityB.
#define W_F0 0.02f
#define W_GLINT_POWER 120.0f
#define W_GLINT_GAIN 0.9f
#define W_CLARITY_G 2.5f
#define W_CLARITY_B 5.0f
#define V_BISECT 20

// Scalars only, no float3 and no structs passed by value: Debian's oclgrind --uninitialized
// crashes on vector shuffles (docs/gpu.md) and cannot run the noalias scope markers that inlining a
// by-value struct argument leaves; this kernel is checked under it.
typedef struct {
  __global const float* z;
  int w, h;
  float cx, cy, zf, zlo, zhi;
} ViewGrid;

// Quad (i, j) and the position inside it of world point (x, y), clamped to the grid.
inline void vg_cell(const ViewGrid* g, const float x, const float y, int* i, int* j, float* ax, float* ay) {
  const float fx = x / g->cx, fy = y / g->cy;
  *i = clamp((int)floor(fx), 0, g->w - 2);
  *j = clamp((int)floor(fy), 0, g->h - 2);
  *ax = clamp(fx - (float)*i, 0.0f, 1.0f);
  *ay = clamp(fy - (float)*j, 0.0f, 1.0f);
}

inline float vg_z(const ViewGrid* g, const int x, const int y) { return g->z[(size_t)y * g->w + x]; }

// Displayed height (metres * z factor) at world (x, y); -inf over a hole; *metres the elevation.
inline float vg_at(const ViewGrid* g, const float x, const float y, float* metres) {
  int i, j;
  float ax, ay;
  vg_cell(g, x, y, &i, &j, &ax, &ay);
  const float a = vg_z(g, i, j), b = vg_z(g, i + 1, j), c = vg_z(g, i, j + 1), d = vg_z(g, i + 1, j + 1);
  if (isnan(a) || isnan(b) || isnan(c) || isnan(d)) return -INFINITY;
  const float z = (1.0f - ay) * ((1.0f - ax) * a + ax * b) + ay * ((1.0f - ax) * c + ax * d);
  *metres = z;
  return z * g->zf;
}

// Central-difference gradient at vertex (i, j); a border or nodata neighbour is replaced by the vertex.
inline void vg_vertex_gradient(const ViewGrid* g, const int i, const int j, float* gx, float* gy) {
  const float c = vg_z(g, i, j);
  int il = i - 1, ir = i + 1, jt = j - 1, jb = j + 1;
  float l = c, r = c, t = c, b = c;
  if (il >= 0 && !isnan(vg_z(g, il, j))) l = vg_z(g, il, j); else il = i;
  if (ir < g->w && !isnan(vg_z(g, ir, j))) r = vg_z(g, ir, j); else ir = i;
  if (jt >= 0 && !isnan(vg_z(g, i, jt))) t = vg_z(g, i, jt); else jt = j;
  if (jb < g->h && !isnan(vg_z(g, i, jb))) b = vg_z(g, i, jb); else jb = j;
  *gx = ir > il ? (r - l) / ((float)(ir - il) * g->cx) : 0.0f;
  *gy = jb > jt ? (b - t) / ((float)(jb - jt) * g->cy) : 0.0f;
}

inline void vg_normal(const ViewGrid* g, const float x, const float y, float* n) {
  int i, j;
  float ax, ay, g0x, g0y, g1x, g1y, g2x, g2y, g3x, g3y;
  vg_cell(g, x, y, &i, &j, &ax, &ay);
  vg_vertex_gradient(g, i, j, &g0x, &g0y);
  vg_vertex_gradient(g, i + 1, j, &g1x, &g1y);
  vg_vertex_gradient(g, i, j + 1, &g2x, &g2y);
  vg_vertex_gradient(g, i + 1, j + 1, &g3x, &g3y);
  const float gx = (1.0f - ay) * ((1.0f - ax) * g0x + ax * g1x) + ay * ((1.0f - ax) * g2x + ax * g3x);
  const float gy = (1.0f - ay) * ((1.0f - ax) * g0y + ax * g1y) + ay * ((1.0f - ax) * g2y + ax * g3y);
  const float nx = -gx * g->zf, ny = -gy * g->zf;
  const float len = sqrt(nx * nx + ny * ny + 1.0f);
  n[0] = nx / len, n[1] = ny / len, n[2] = 1.0f / len;
}

// Clips the ray o + t d (t >= 0) to the grid's box; 0 when it misses.
inline int vg_clip(const ViewGrid* g, const float* oo, const float* dd, float* t0, float* t1) {
  float lo[3], hi[3];
  lo[0] = 0.0f, lo[1] = 0.0f, lo[2] = g->zlo;
  hi[0] = (float)(g->w - 1) * g->cx, hi[1] = (float)(g->h - 1) * g->cy, hi[2] = g->zhi;
  float a0 = 0.0f, a1 = INFINITY;
  for (int k = 0; k < 3; ++k) {
    if (fabs(dd[k]) < 1e-12f) {
      if (oo[k] < lo[k] || oo[k] > hi[k]) return 0;
      continue;
    }
    float a = (lo[k] - oo[k]) / dd[k], b = (hi[k] - oo[k]) / dd[k];
    if (a > b) {
      const float s = a;
      a = b;
      b = s;
    }
    a0 = fmax(a0, a);
    a1 = fmin(a1, b);
  }
  *t0 = a0;
  *t1 = a1;
  return a0 < a1;
}

inline float vg_step(const ViewGrid* g, const float* d) {
  return 0.5f * fmin(g->cx, g->cy) / fmax(sqrt(d[0] * d[0] + d[1] * d[1]), 1e-12f);
}

// Height of the ray above the surface at t (+inf over a hole).
inline float vg_above(const ViewGrid* g, const float* o, const float* d, const float t) {
  float m;
  return o[2] + t * d[2] - vg_at(g, o[0] + t * d[0], o[1] + t * d[1], &m);
}

// 1 when a march toward the sun from o finds no surface above it (or shadows are off).
inline float vg_lit(const ViewGrid* g, __global const float* p, const float* o, const float* sun) {
  float u0, u1;
  if (p[V_SHADOWS] == 0.0f || !vg_clip(g, o, sun, &u0, &u1)) return 1.0f;
  const float ds = vg_step(g, sun);
  for (int k = 1; (float)k * ds < u1; ++k)
    if (vg_above(g, o, sun, (float)k * ds) < 0.0f) return 0.0f;
  return 1.0f;
}

// Shaded (unhazed) terrain colour at world (x, y); lit < 0: march for its own shadow.
inline void vg_terrain(const ViewGrid* g, __global const float* p, const float x, const float y, const float lit,
                       const float* sun, __global const float* ramp_z, __global const uchar* ramp_rgb,
                       const int nramp, const uint nodata_rgb, float* rgb) {
  float zm = 0.0f;
  const float zs = vg_at(g, x, y, &zm);
  float n[3], alb[3];
  vg_normal(g, x, y, n);
  if (p[V_MATERIAL] != 0.0f) {
    const float e = (zm - p[V_BASE]) * p[V_INV_RANGE];
    // The true slope's cosine: the material follows the ground, not its exaggeration.
    const float q = (n[0] * n[0] + n[1] * n[1]) * p[V_INV_ZF] * p[V_INV_ZF] / (n[2] * n[2]);
    natural_albedo(x, y, e, e - p[V_SNOW_E], 1.0f / sqrt(q + 1.0f), p[V_LAMBDA], p[V_WATER] != 0.0f, alb);
  } else {
    uchar a[3];
    ramp_color(zm, ramp_z, ramp_rgb, nramp, nodata_rgb, a);
    alb[0] = (float)a[0], alb[1] = (float)a[1], alb[2] = (float)a[2];
  }
  float light = fmax(0.0f, n[0] * sun[0] + n[1] * sun[1] + n[2] * sun[2]);
  if (light > 0.0f && lit < 0.0f) {
    // March toward the sun from just above the hit; any surface above the ray shadows it.
    float o[3];
    o[0] = x, o[1] = y, o[2] = zs + 1e-4f * fmax(g->zhi - g->zlo, 1.0f);
    light *= vg_lit(g, p, o, sun);
  } else if (lit >= 0.0f) {
    light *= lit;
  }
  const float shade = p[V_AMBIENT] + p[V_DIFFUSE] * light;
  rgb[0] = alb[0] * shade, rgb[1] = alb[1] * shade, rgb[2] = alb[2] * shade;
}

__kernel void render_view(__global const float* z, const int w, const int h, __global const float* p,
                          __global const float* ramp_z, __global const uchar* ramp_rgb, const int nramp,
                          const uint nodata_rgb, const int pw, const int ph, __global uchar* out) {
  const int px = (int)get_global_id(0), py = (int)get_global_id(1);
  if (px >= pw || py >= ph) return;
  ViewGrid g;
  g.z = z, g.w = w, g.h = h;
  g.cx = p[V_CX], g.cy = p[V_CY], g.zf = p[V_ZF], g.zlo = p[V_ZLO], g.zhi = p[V_ZHI];
  const float sx = 2.0f * ((float)px + 0.5f) / (float)pw - 1.0f, sy = 1.0f - 2.0f * ((float)py + 0.5f) / (float)ph;
  float eye[3], d[3], sun[3];
  for (int k = 0; k < 3; ++k) {
    eye[k] = p[V_EYE + k];
    sun[k] = p[V_SUN + k];
    d[k] = p[V_FWD + k] + sx * p[V_RIGHT + k] + sy * p[V_UP + k];
  }
  const float dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (int k = 0; k < 3; ++k) d[k] = d[k] / dl;
  // Sky colours as scalars: a constant array would become a program-scope variable, on which
  // oclgrind's --uninitialized plugin crashes at build time.
  const float sky_h0 = 214.0f, sky_h1 = 226.0f, sky_h2 = 236.0f;
  const float sky_z0 = 112.0f, sky_z1 = 152.0f, sky_z2 = 204.0f;
  const float sk = sqrt(clamp(d[2], 0.0f, 1.0f));
  float rgb[3];
  rgb[0] = sky_h0 + sk * (sky_z0 - sky_h0);
  rgb[1] = sky_h1 + sk * (sky_z1 - sky_h1);
  rgb[2] = sky_h2 + sk * (sky_z2 - sky_h2);
  float t0 = 0.0f, t1, thit = -1.0f;
  if (vg_clip(&g, eye, d, &t0, &t1)) {
    const float dt = vg_step(&g, d);
    float tp = t0, fp = vg_above(&g, eye, d, t0);
    // A ray entering the box below the surface (through a side) sees no terrain: no skirts.
    for (int k = 1; fp > 0.0f; ++k) {
      float t = t0 + (float)k * dt;
      const int last = t >= t1;
      if (last) t = t1;
      const float ft = vg_above(&g, eye, d, t);
      if (ft <= 0.0f) {
        float a = tp, b = t;
        for (int it = 0; it < V_BISECT; ++it) {
          const float m = 0.5f * (a + b);
          if (vg_above(&g, eye, d, m) > 0.0f)
            a = m;
          else
            b = m;
        }
        thit = b;
        break;
      }
      if (last) break;
      tp = t;
      fp = ft;
    }
  }
  // The water plane, where the ray meets it over the grid before any terrain.
  const float wz = p[V_WATER_Z];
  float tw = -1.0f;
  if (p[V_WATER] != 0.0f && d[2] < 0.0f && eye[2] > wz) {
    const float t = (wz - eye[2]) / d[2];
    const float x = eye[0] + t * d[0], y = eye[1] + t * d[1];
    if (x >= 0.0f && x <= (float)(w - 1) * g.cx && y >= 0.0f && y <= (float)(h - 1) * g.cy && (thit < 0.0f || t < thit))
      tw = t;
  }
  // A ray entering the box below the water through a side sees no sea floor: no water skirts.
  if (p[V_WATER] != 0.0f && tw < 0.0f && thit >= 0.0f && eye[2] + t0 * d[2] < wz) thit = -1.0f;
  float tdist = -1.0f, col[3];
  if (tw >= 0.0f) {
    float o[3];
    o[0] = eye[0] + tw * d[0], o[1] = eye[1] + tw * d[1], o[2] = wz + 1e-4f * fmax(g.zhi - g.zlo, 1.0f);
    const float lit = sun[2] > 0.0f ? vg_lit(&g, p, o, sun) : 0.0f;
    // Beer-Lambert along the ray's path through the water (metres: vertical lengths undo the z
    // factor) toward the deep colour, lit by the sun like a flat surface.
    const float izf = p[V_INV_ZF];
    const float path = thit >= 0.0f ? (thit - tw) * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] * izf * izf) : INFINITY;
    float bed[3];
    bed[0] = 0.0f, bed[1] = 0.0f, bed[2] = 0.0f;
    if (thit >= 0.0f)
      vg_terrain(&g, p, eye[0] + thit * d[0], eye[1] + thit * d[1], lit, sun, ramp_z, ramp_rgb, nramp, nodata_rgb, bed);
    const float body_shade = p[V_AMBIENT] + p[V_DIFFUSE] * fmax(0.0f, sun[2]) * lit;
    const float cl = p[V_CLARITY];
    // Fresnel (Schlick) toward the sky seen in the mirror direction, plus the sun's glint.
    const float c = clamp(-d[2], 0.0f, 1.0f), m = 1.0f - c;
    const float fr = W_F0 + (1.0f - W_F0) * m * m * m * m * m;
    const float rs = sqrt(c);
    const float refl = fmax(0.0f, d[0] * sun[0] + d[1] * sun[1] - d[2] * sun[2]);
    const float glint = lit * W_GLINT_GAIN * 255.0f * pow(refl, W_GLINT_POWER);
    const float tr0 = exp(-path / cl), tr1 = exp(-path / (cl * W_CLARITY_G)), tr2 = exp(-path / (cl * W_CLARITY_B));
    col[0] = (1.0f - fr) * (bed[0] * tr0 + p[V_DEEP] * body_shade * (1.0f - tr0)) +
             fr * (sky_h0 + rs * (sky_z0 - sky_h0)) + glint;
    col[1] = (1.0f - fr) * (bed[1] * tr1 + p[V_DEEP + 1] * body_shade * (1.0f - tr1)) +
             fr * (sky_h1 + rs * (sky_z1 - sky_h1)) + glint;
    col[2] = (1.0f - fr) * (bed[2] * tr2 + p[V_DEEP + 2] * body_shade * (1.0f - tr2)) +
             fr * (sky_h2 + rs * (sky_z2 - sky_h2)) + glint;
    tdist = tw;
  } else if (thit >= 0.0f) {
    vg_terrain(&g, p, eye[0] + thit * d[0], eye[1] + thit * d[1], -1.0f, sun, ramp_z, ramp_rgb, nramp, nodata_rgb, col);
    tdist = thit;
  }
  if (tdist >= 0.0f) {
    const float hz =
        p[V_HAZE] > 0.0f ? 1.0f - exp(-p[V_HAZE] * fmax(0.0f, tdist - p[V_HAZE_NEAR]) / p[V_HAZE_SCALE]) : 0.0f;
    rgb[0] = col[0] * (1.0f - hz) + sky_h0 * hz;
    rgb[1] = col[1] * (1.0f - hz) + sky_h1 * hz;
    rgb[2] = col[2] * (1.0f - hz) + sky_h2 * hz;
  }
  __global uchar* o = out + ((size_t)py * pw + px) * 3;
  for (int c = 0; c < 3; ++c) o[c] = rw_byte(rgb[c]);
}
