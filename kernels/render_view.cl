// Perspective picture of a heightfield (render --mode perspective), one work-item per pixel: the
// pixel's ray is clipped to the grid's box, marched against the bilinear surface in steps of half a
// cell, the first crossing refined by bisection, shaded by the sun (Lambert + ambient on the
// interpolated vertex normals, a march toward the sun for cast shadows), coloured by the ramp at
// the hit's elevation and hazed toward the sky with distance. Nodata quads are holes. Host
// reference, step for step in double: host/src/render/view.cpp (slots: view_slots()).
#pragma OPENCL FP_CONTRACT OFF
#include "render_window.clh"
#include "render_ramp.clh"

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
#define V_BISECT 20
#define V_SKY_H ((float3)(214.0f, 226.0f, 236.0f))
#define V_SKY_Z ((float3)(112.0f, 152.0f, 204.0f))

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
inline float2 vg_vertex_gradient(const ViewGrid* g, const int i, const int j) {
  const float c = vg_z(g, i, j);
  int il = i - 1, ir = i + 1, jt = j - 1, jb = j + 1;
  float l = c, r = c, t = c, b = c;
  if (il >= 0 && !isnan(vg_z(g, il, j))) l = vg_z(g, il, j); else il = i;
  if (ir < g->w && !isnan(vg_z(g, ir, j))) r = vg_z(g, ir, j); else ir = i;
  if (jt >= 0 && !isnan(vg_z(g, i, jt))) t = vg_z(g, i, jt); else jt = j;
  if (jb < g->h && !isnan(vg_z(g, i, jb))) b = vg_z(g, i, jb); else jb = j;
  return (float2)(ir > il ? (r - l) / ((float)(ir - il) * g->cx) : 0.0f,
                  jb > jt ? (b - t) / ((float)(jb - jt) * g->cy) : 0.0f);
}

inline float3 vg_normal(const ViewGrid* g, const float x, const float y) {
  int i, j;
  float ax, ay;
  vg_cell(g, x, y, &i, &j, &ax, &ay);
  const float2 g0 = vg_vertex_gradient(g, i, j), g1 = vg_vertex_gradient(g, i + 1, j);
  const float2 g2 = vg_vertex_gradient(g, i, j + 1), g3 = vg_vertex_gradient(g, i + 1, j + 1);
  const float gx = (1.0f - ay) * ((1.0f - ax) * g0.x + ax * g1.x) + ay * ((1.0f - ax) * g2.x + ax * g3.x);
  const float gy = (1.0f - ay) * ((1.0f - ax) * g0.y + ax * g1.y) + ay * ((1.0f - ax) * g2.y + ax * g3.y);
  const float3 n = (float3)(-gx * g->zf, -gy * g->zf, 1.0f);
  return n / sqrt(dot(n, n));
}

// Clips the ray o + t d (t >= 0) to the grid's box; 0 when it misses.
inline int vg_clip(const ViewGrid* g, const float3 o, const float3 d, float* t0, float* t1) {
  const float lo[3] = {0.0f, 0.0f, g->zlo};
  const float hi[3] = {(float)(g->w - 1) * g->cx, (float)(g->h - 1) * g->cy, g->zhi};
  const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
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

inline float vg_step(const ViewGrid* g, const float3 d) {
  return 0.5f * fmin(g->cx, g->cy) / fmax(sqrt(d.x * d.x + d.y * d.y), 1e-12f);
}

// Height of the ray above the surface at t (+inf over a hole).
inline float vg_above(const ViewGrid* g, const float3 o, const float3 d, const float t) {
  float m;
  return o.z + t * d.z - vg_at(g, o.x + t * d.x, o.y + t * d.y, &m);
}

__kernel void render_view(__global const float* z, const int w, const int h, __global const float* p,
                          __global const float* ramp_z, __global const uchar* ramp_rgb, const int nramp,
                          const uint nodata_rgb, const int pw, const int ph, __global uchar* out) {
  const int px = (int)get_global_id(0), py = (int)get_global_id(1);
  if (px >= pw || py >= ph) return;
  ViewGrid g;
  g.z = z, g.w = w, g.h = h;
  g.cx = p[V_CX], g.cy = p[V_CY], g.zf = p[V_ZF], g.zlo = p[V_ZLO], g.zhi = p[V_ZHI];
  const float3 eye = (float3)(p[V_EYE], p[V_EYE + 1], p[V_EYE + 2]);
  const float3 fwd = (float3)(p[V_FWD], p[V_FWD + 1], p[V_FWD + 2]);
  const float3 right = (float3)(p[V_RIGHT], p[V_RIGHT + 1], p[V_RIGHT + 2]);
  const float3 up = (float3)(p[V_UP], p[V_UP + 1], p[V_UP + 2]);
  const float3 sun = (float3)(p[V_SUN], p[V_SUN + 1], p[V_SUN + 2]);
  const float sx = 2.0f * ((float)px + 0.5f) / (float)pw - 1.0f, sy = 1.0f - 2.0f * ((float)py + 0.5f) / (float)ph;
  float3 d = fwd + sx * right + sy * up;
  d = d / sqrt(dot(d, d));
  const float sk = sqrt(clamp(d.z, 0.0f, 1.0f));
  float3 rgb = V_SKY_H + sk * (V_SKY_Z - V_SKY_H);
  float t0, t1;
  if (vg_clip(&g, eye, d, &t0, &t1)) {
    const float dt = vg_step(&g, d);
    float tp = t0, fp = vg_above(&g, eye, d, t0), thit = -1.0f;
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
    if (thit >= 0.0f) {
      const float x = eye.x + thit * d.x, y = eye.y + thit * d.y;
      float zm = 0.0f;
      const float zs = vg_at(&g, x, y, &zm);
      uchar alb[3];
      ramp_color(zm, ramp_z, ramp_rgb, nramp, nodata_rgb, alb);
      const float3 n = vg_normal(&g, x, y);
      float light = fmax(0.0f, dot(n, sun));
      if (light > 0.0f && p[V_SHADOWS] != 0.0f) {
        const float3 o = (float3)(x, y, zs + 1e-4f * fmax(g.zhi - g.zlo, 1.0f));
        float u0, u1;
        if (vg_clip(&g, o, sun, &u0, &u1)) {
          const float ds = vg_step(&g, sun);
          for (int k = 1; (float)k * ds < u1; ++k) {
            if (vg_above(&g, o, sun, (float)k * ds) < 0.0f) {
              light = 0.0f;
              break;
            }
          }
        }
      }
      const float shade = p[V_AMBIENT] + p[V_DIFFUSE] * light;
      const float hz =
          p[V_HAZE] > 0.0f ? 1.0f - exp(-p[V_HAZE] * fmax(0.0f, thit - p[V_HAZE_NEAR]) / p[V_HAZE_SCALE]) : 0.0f;
      rgb = (float3)((float)alb[0], (float)alb[1], (float)alb[2]) * shade * (1.0f - hz) + V_SKY_H * hz;
    }
  }
  __global uchar* o = out + ((size_t)py * pw + px) * 3;
  o[0] = rw_byte(rgb.x);
  o[1] = rw_byte(rgb.y);
  o[2] = rw_byte(rgb.z);
}
