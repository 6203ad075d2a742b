// Skeleton primitives for gradient-domain authoring (paper section 4.3):
//   * apply_tensor_field: the composite tensor field A(p) = I + sum_i mu_i alpha(d_i/r_i) T_i(p, u(p))
//     applied to a staggered gradient, g' = A g (or g += A delta to orient a noise layer);
//   * primitive_weight: the falloff weight max_i alpha(d_i/r_i) (masks for brushes and noise);
//   * profile_potential + add_potential_gradient: g += the discrete gradient of sum_i P_i(d_i), a
//     cross-section profile of the distance to a curve (crests, faults, ravines, river banks, rims).
// Positions are metres: cell (x, y) is at (x * cx, y * cy), y growing southwards.
// Each primitive is 16 floats (layout in host/src/tensor.cpp); vertices are float4 (x, y, amp, 0).
// Kernels run over a bounding box (x0, y0, bw, bh) of the grid, one work-item per row.
#pragma OPENCL FP_CONTRACT OFF

#define SHAPE_POINT 0
#define SHAPE_POLYLINE 1
#define SHAPE_DISC 2
#define SHAPE_POLYGON 3

#define TENSOR_DIRECTIONAL 0
#define TENSOR_SCALE 1
#define TENSOR_TANGENT 2
#define TENSOR_CLOSEST 3

#define PROFILE_ROUND 0
#define PROFILE_SHARP 1
#define PROFILE_STEP 2
#define PROFILE_DROP 3

// alpha(t) = (1 - t^2)^3: alpha(0) = 1, alpha(1) = alpha'(1) = alpha''(1) = 0, even in t (so smooth
// at the skeleton), zero outside [0, 1].
float alpha_fn(float t) {
  if (t >= 1.0f) return 0.0f;
  const float s = 1.0f - t * t;
  return s * s * s;
}
float alpha_deriv(float t) {
  if (t >= 1.0f) return 0.0f;
  const float s = 1.0f - t * t;
  return -6.0f * t * s * s;
}
// 0 -> 0, 1 -> 1 with zero first and second derivatives at both ends (C2 step).
float smoother(float t) {
  t = clamp(t, 0.0f, 1.0f);
  return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}
float smoother_deriv(float t) {
  if (t <= 0.0f || t >= 1.0f) return 0.0f;
  const float u = t * (1.0f - t);
  return 30.0f * u * u;
}

typedef struct {
  float dist;     // distance in the (anisotropic) metric; 0 inside filled shapes
  float sdist;    // signed: right of a polyline / outside a filled shape is positive
  float2 grad;    // gradient of sdist in real space (unit for isotropic metrics)
  float2 tangent; // unit tangent of the closest segment (polylines, polygons)
  float2 toward;  // unit direction from p towards the closest point u(p)
  float amp;      // vertex amplitude interpolated at the closest point
  float beyond;   // distance past the end of an open polyline (0 along it)
} Closest;

float2 metric_apply(__global const float* pr, float2 v) {
  return (float2)(pr[8] * v.x + pr[9] * v.y, pr[10] * v.x + pr[11] * v.y);
}
// Real-space gradient of |M v| given the unit vector n = M v / |M v|: M^T n.
float2 metric_transpose(__global const float* pr, float2 n) {
  return (float2)(pr[8] * n.x + pr[10] * n.y, pr[9] * n.x + pr[11] * n.y);
}

Closest closest_point(__global const float* pr, __global const float4* verts, float2 p) {
  Closest c;
  c.dist = MAXFLOAT;
  c.sdist = MAXFLOAT;
  c.grad = (float2)(0.0f, 0.0f);
  c.tangent = (float2)(1.0f, 0.0f);
  c.toward = (float2)(0.0f, 0.0f);
  c.amp = 0.0f;
  c.beyond = 0.0f;
  const int shape = (int)pr[0];
  const int v0 = (int)pr[1];
  const int nv = (int)pr[2];
  const float2 P = metric_apply(pr, p);
  if (shape == SHAPE_POINT || shape == SHAPE_DISC) {
    const float4 v = verts[v0];
    const float2 d = P - metric_apply(pr, v.xy);
    const float len = length(d);
    const float R = shape == SHAPE_DISC ? pr[7] : 0.0f;
    c.sdist = len - R;
    c.dist = fmax(c.sdist, 0.0f);
    c.grad = len > 0.0f ? metric_transpose(pr, d / len) : (float2)(0.0f, 0.0f);
    const float2 tq = v.xy - p;
    const float tql = length(tq);
    c.toward = tql > 0.0f ? tq / tql : (float2)(0.0f, 0.0f);
    c.tangent = (float2)(-c.toward.y, c.toward.x);
    c.amp = v.z;
    return c;
  }
  const int closed = shape == SHAPE_POLYGON;
  const int nseg = closed ? nv : nv - 1;
  float best = MAXFLOAT;
  float side = 1.0f;
  float2 n = (float2)(0.0f, 0.0f);
  int inside = 0;
  // Pass 1: the closest segment by squared distance only (and the crossing number); the closest
  // point's other attributes (four square roots, divisions) are derived once, for that segment.
  int bs = -1;
  for (int s = 0; s < nseg; ++s) {
    const float4 a4 = verts[v0 + s];
    const float4 b4 = verts[v0 + ((s + 1) % nv)];
    const float2 A = metric_apply(pr, a4.xy), B = metric_apply(pr, b4.xy);
    const float2 ab = B - A;
    const float l2 = dot(ab, ab);
    const float traw = l2 > 0.0f ? dot(P - A, ab) / l2 : 0.0f;
    const float t = clamp(traw, 0.0f, 1.0f);
    const float2 d = P - (A + t * ab);
    const float d2 = dot(d, d);
    if (d2 < best) {
      best = d2;
      bs = s;
    }
    if (closed && ((a4.y <= p.y) != (b4.y <= p.y))) {  // crossing number, real coordinates
      const float xi = a4.x + (p.y - a4.y) / (b4.y - a4.y) * (b4.x - a4.x);
      if (p.x < xi) inside ^= 1;
    }
  }
  if (bs >= 0) {
    const int s = bs;
    const float4 a4 = verts[v0 + s];
    const float4 b4 = verts[v0 + ((s + 1) % nv)];
    const float2 A = metric_apply(pr, a4.xy), B = metric_apply(pr, b4.xy);
    const float2 ab = B - A;
    const float l2 = dot(ab, ab);
    const float traw = l2 > 0.0f ? dot(P - A, ab) / l2 : 0.0f;
    const float t = clamp(traw, 0.0f, 1.0f);
    const float2 d = P - (A + t * ab);
    const float d2 = dot(d, d);
    const float len = sqrt(d2);
    const float2 tan_real = b4.xy - a4.xy;
    const float tl = length(tan_real);
    c.tangent = tl > 0.0f ? tan_real / tl : (float2)(1.0f, 0.0f);
    const float2 tq = a4.xy + t * tan_real - p;
    const float tql = length(tq);
    c.toward = tql > 0.0f ? tq / tql : (float2)(0.0f, 0.0f);
    c.amp = a4.z + t * (b4.z - a4.z);
    // Side: (-ab.y, ab.x) is "right" (positive); with x east and y south that is the travel
    // direction turned clockwise on a north-up map.
    const float cr = ab.x * (P.y - A.y) - ab.y * (P.x - A.x);
    side = cr >= 0.0f ? 1.0f : -1.0f;
    const float al = sqrt(l2);
    n = len > 0.0f ? d / len : (al > 0.0f ? (float2)(-ab.y, ab.x) / al : (float2)(0.0f, 0.0f));
    c.dist = len;
    c.beyond = 0.0f;
    if (!closed) {
      if (s == 0 && traw < 0.0f) c.beyond = -traw * al;
      if (s == nseg - 1 && traw > 1.0f) c.beyond = (traw - 1.0f) * al;
    }
  }
  if (closed) {
    // Filled shape: distance 0 inside, sdist negative inside, grad pointing outwards.
    const float sgn = inside ? -1.0f : 1.0f;
    c.sdist = sgn * c.dist;
    c.grad = metric_transpose(pr, n * (c.dist > 0.0f ? sgn : 1.0f));
    if (inside) c.dist = 0.0f;
  } else {
    c.sdist = side * c.dist;
    // d/|d| already points away from the curve; on the curve n is the right normal.
    c.grad = metric_transpose(pr, c.dist > 0.0f ? n * side : n);
  }
  return c;
}

// Weight of primitive i at p (alpha of the distance over the radius).
float prim_weight(__global const float* pr, Closest c) {
  const float r = pr[3];
  return r > 0.0f ? alpha_fn(c.dist / r) : (c.dist <= 0.0f ? 1.0f : 0.0f);
}

// The traceless direction tensor R(2 theta) = [[cos 2t, sin 2t], [sin 2t, -cos 2t]] for a unit
// direction (cos t, sin t): cos 2t = c^2 - s^2, sin 2t = 2 c s.
float4 dir_tensor(float2 u) { return (float4)(u.x * u.x - u.y * u.y, 2.0f * u.x * u.y, 2.0f * u.x * u.y, u.y * u.y - u.x * u.x); }

float4 tensor_at(__global const float* prims, int nprims, __global const float4* verts, float2 p) {
  float4 A = (float4)(1.0f, 0.0f, 0.0f, 1.0f);
  for (int i = 0; i < nprims; ++i) {
    __global const float* pr = prims + 16 * i;
    const Closest c = closest_point(pr, verts, p);
    const float w = pr[4] * prim_weight(pr, c);
    if (w == 0.0f) continue;
    const int kind = (int)pr[5];
    float4 T;
    if (kind == TENSOR_SCALE) {
      T = (float4)(1.0f, 0.0f, 0.0f, 1.0f);
    } else if (kind == TENSOR_DIRECTIONAL) {
      // pr[14], pr[15] = cos, sin of 2 angle (computed once on the host, not per face).
      T = (float4)(pr[14], pr[15], pr[15], -pr[14]);
    } else {
      // Aligned with the stroke's tangent or with u(p); the angle (pr[14], pr[15] = its cos, sin)
      // adds a rotation (e.g. pi/2).
      float2 u = kind == TENSOR_TANGENT ? c.tangent : c.toward;
      const float cs = pr[14], sn = pr[15];
      u = (float2)(cs * u.x - sn * u.y, sn * u.x + cs * u.y);
      T = dir_tensor(u);
    }
    A += w * T;
  }
  return A;
}

// Mean of the other component's up-to-four faces around a face (missing faces are skipped).
float other_at_x_face(__global const float* gy, int x, int y, int W, int H) {
  float s = 0.0f;
  int n = 0;
  for (int dy = -1; dy <= 0; ++dy)
    for (int dx = 0; dx <= 1; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < W && yy >= 0 && yy < H - 1) {
        s += gy[(size_t)yy * W + xx];
        ++n;
      }
    }
  return n ? s / (float)n : 0.0f;
}
float other_at_y_face(__global const float* gx, int x, int y, int W, int H) {
  float s = 0.0f;
  int n = 0;
  for (int dy = 0; dy <= 1; ++dy)
    for (int dx = -1; dx <= 0; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (yy < H && xx >= 0 && xx < W - 1) {
        s += gx[(size_t)yy * W + xx];
        ++n;
      }
    }
  return n ? s / (float)n : 0.0f;
}

// dst = (add ? dst : 0) + A src on the faces of the box. The tensor is sampled at the face centres.
// src and dst must be different buffers (src's other component is interpolated around each face).
__kernel void apply_tensor_field(__global const float* sx, __global const float* sy, __global float* dx,
                                 __global float* dy, const int W, const int H, const float cx, const float cy,
                                 const int x0, const int y0, const int bw, const int bh,
                                 __global const float* prims, const int nprims, __global const float4* verts,
                                 const int add) {
  const int j = get_global_id(0);
  if (j >= bh) return;
  const int y = y0 + j;
  for (int x = x0; x < x0 + bw; ++x) {
    const size_t o = (size_t)y * W + x;
    // A zero input gives a zero output: skip the tensor (most of a noise layer's box in add mode).
    if (x < W - 1) {
      const float gxv = sx[o], gyv = other_at_x_face(sy, x, y, W, H);
      float v = 0.0f;
      if (gxv != 0.0f || gyv != 0.0f) {
        const float4 A = tensor_at(prims, nprims, verts, (float2)(((float)x + 0.5f) * cx, (float)y * cy));
        v = A.x * gxv + A.y * gyv;
      }
      dx[o] = add ? dx[o] + v : v;
    }
    if (y < H - 1) {
      const float gxv = other_at_y_face(sx, x, y, W, H), gyv = sy[o];
      float v = 0.0f;
      if (gxv != 0.0f || gyv != 0.0f) {
        const float4 A = tensor_at(prims, nprims, verts, (float2)((float)x * cx, ((float)y + 0.5f) * cy));
        v = A.z * gxv + A.w * gyv;
      }
      dy[o] = add ? dy[o] + v : v;
    }
  }
}

// w = max_i alpha(d_i / r_i) at cell centres (invert: 1 - that), written on the box only.
__kernel void primitive_weight(__global float* w, const int W, const int H, const float cx, const float cy,
                               const int x0, const int y0, const int bw, const int bh,
                               __global const float* prims, const int nprims, __global const float4* verts,
                               const int invert) {
  const int j = get_global_id(0);
  if (j >= bh) return;
  const int y = y0 + j;
  for (int x = x0; x < x0 + bw; ++x) {
    const float2 p = (float2)((float)x * cx, (float)y * cy);
    float m = 0.0f;
    for (int i = 0; i < nprims; ++i) {
      __global const float* pr = prims + 16 * i;
      m = fmax(m, prim_weight(pr, closest_point(pr, verts, p)));
    }
    w[(size_t)y * W + x] = invert ? 1.0f - m : m;
  }
}

// Value of primitive i's profile P_i at p. pr[12] = profile kind, pr[13] = amplitude scale.
// ROUND: P = a alpha(d/r); SHARP: P = a (1 - d/r)^3; STEP: P = a smoother((s/r + 1)/2) across a
// signed distance s (a fault of throw a); DROP: P = -a smoother(s/r) for s >= 0 (a cliff face, a mesa
// rim). a = pr[13] * the vertex amplitude at the closest point. Open-curve signed profiles taper off
// past the curve's ends (times alpha(beyond/r)) so that a finite fault dies out.
float profile_value(__global const float* pr, Closest c) {
  const float r = pr[3];
  if (r <= 0.0f) return 0.0f;
  const int kind = (int)pr[12];
  const float a = pr[13] * c.amp;
  float P;
  if (kind == PROFILE_ROUND) {
    P = a * alpha_fn(c.dist / r);
  } else if (kind == PROFILE_SHARP) {
    const float t = fmin(c.dist / r, 1.0f);
    P = a * (1.0f - t) * (1.0f - t) * (1.0f - t);
  } else if (kind == PROFILE_STEP) {
    P = a * smoother((c.sdist / r + 1.0f) * 0.5f);
  } else {
    P = -a * smoother(c.sdist / r);
  }
  if ((kind == PROFILE_STEP || kind == PROFILE_DROP) && c.beyond > 0.0f) P *= alpha_fn(c.beyond / r);
  return P;
}

// P = sum_i P_i at the cell centres of the box (into `pot`).
__kernel void profile_potential(__global float* pot, const int W, const int H, const float cx, const float cy,
                                const int x0, const int y0, const int bw, const int bh,
                                __global const float* prims, const int nprims, __global const float4* verts) {
  const int j = get_global_id(0);
  if (j >= bh) return;
  const int y = y0 + j;
  for (int x = x0; x < x0 + bw; ++x) {
    const float2 p = (float2)((float)x * cx, (float)y * cy);
    float P = 0.0f;
    for (int i = 0; i < nprims; ++i) {
      __global const float* pr = prims + 16 * i;
      P += profile_value(pr, closest_point(pr, verts, p));
    }
    pot[(size_t)y * W + x] = P;
  }
}

// g += the staggered gradient of the potential on the faces between two cells of the box: the exact
// discrete gradient of P, so it is curl-free and the solve reproduces P (profiles superpose additively).
// The box extends past every support, so faces leaving it carry no gradient.
__kernel void add_potential_gradient(__global float* gx, __global float* gy, __global const float* pot, const int W,
                                     const int H, const float cx, const float cy, const int x0, const int y0,
                                     const int bw, const int bh) {
  const int j = get_global_id(0);
  if (j >= bh) return;
  const int y = y0 + j;
  const float icx = 1.0f / cx, icy = 1.0f / cy;
  for (int x = x0; x < x0 + bw; ++x) {
    const size_t o = (size_t)y * W + x;
    if (x + 1 < x0 + bw) gx[o] += (pot[o + 1] - pot[o]) * icx;
    if (j + 1 < bh) gy[o] += (pot[o + W] - pot[o]) * icy;
  }
}
