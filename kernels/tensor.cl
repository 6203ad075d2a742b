// Skeleton primitives for gradient-domain authoring (paper section 4.3):
//   * apply_tensor_field: the composite tensor field A(p) = I + sum_i mu_i alpha(d_i/r_i) T_i(p, u(p))
//     applied to a staggered gradient, g' = A g (or g += A delta to orient a noise layer);
//   * primitive_field: the falloff weight max_i alpha(d_i/r_i) (masks for brushes and noise), or the
//     potential sum_i P_i(d_i), a cross-section profile of the distance to a curve (crests, faults,
//     ravines, river banks, rims), whose discrete gradient add_potential_gradient adds to g.
// Positions are metres: cell (x, y) is at (x * cx, y * cy), y growing southwards.
// Each primitive is 16 floats (layout in host/src/tensor.cpp); vertices are float4 (x, y, amp, 0).
// Kernels run over a bounding box (x0, y0, bw, bh) of the grid, one work-item per row, VW cells of
// the row at a time in explicit vectors: PoCL vectorises across work-items only for loop-free kernels,
// and the per-primitive and per-segment loops here would otherwise run scalar (8x slower on AVX2).
// Per-primitive data (shape, vertex count, kind) is uniform across the lanes, so only the closest
// segment differs per lane: it is chosen by selects, never by branches.
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

#include "vec8.clh"

// alpha(t) = (1 - t^2)^3: alpha(0) = 1, alpha(1) = alpha'(1) = alpha''(1) = 0, even in t (so smooth
// at the skeleton), zero outside [0, 1].
vf alpha_v(vf t) {
  const vf s = 1.0f - t * t;
  return select(s * s * s, (vf)(0.0f), t >= 1.0f);
}
// 0 -> 0, 1 -> 1 with zero first and second derivatives at both ends (C2 step).
vf smoother_v(vf t) {
  t = clamp(t, 0.0f, 1.0f);
  return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

// The closest point of a primitive to VW positions.
typedef struct {
  vf dist;        // distance in the (anisotropic) metric; 0 inside filled shapes
  vf sdist;       // signed: right of a polyline / outside a filled shape is positive
  vf gx, gy;      // gradient of sdist in real space (unit for isotropic metrics)
  vf tx, ty;      // unit tangent of the closest segment (polylines, polygons)
  vf ux, uy;      // unit direction from p towards the closest point u(p)
  vf amp;         // vertex amplitude interpolated at the closest point
  vf beyond;      // distance past the end of an open polyline (0 along it)
} ClosestV;

// Anisotropic metric M = pr[8..11] (row-major); distances are |M (p - q)|, and the real-space
// gradient of |M v| is M^T (M v / |M v|).
ClosestV closest_v(__global const float* pr, __global const float4* verts, vf px, vf py) {
  ClosestV c;
  const int shape = (int)pr[0];
  const int v0 = (int)pr[1];
  const int nv = (int)pr[2];
  const float m00 = pr[8], m01 = pr[9], m10 = pr[10], m11 = pr[11];
  const vf zero = (vf)(0.0f), one = (vf)(1.0f);
  const vf Px = m00 * px + m01 * py, Py = m10 * px + m11 * py;
  c.beyond = zero;
  if (shape == SHAPE_POINT || shape == SHAPE_DISC) {
    const float4 v = verts[v0];
    const float Vx = m00 * v.x + m01 * v.y, Vy = m10 * v.x + m11 * v.y;
    const vf dx = Px - Vx, dy = Py - Vy;
    const vf len = sqrt(dx * dx + dy * dy);
    const float R = shape == SHAPE_DISC ? pr[7] : 0.0f;
    c.sdist = len - R;
    c.dist = fmax(c.sdist, zero);
    const vi pos = len > zero;
    const vf nx = select(zero, dx / len, pos), ny = select(zero, dy / len, pos);
    c.gx = m00 * nx + m10 * ny;
    c.gy = m01 * nx + m11 * ny;
    const vf qx = v.x - px, qy = v.y - py;
    const vf ql = sqrt(qx * qx + qy * qy);
    const vi qpos = ql > zero;
    c.ux = select(zero, qx / ql, qpos);
    c.uy = select(zero, qy / ql, qpos);
    c.tx = -c.uy;
    c.ty = c.ux;
    c.amp = (vf)(v.z);
    return c;
  }
  const int closed = shape == SHAPE_POLYGON;
  const int nseg = closed ? nv : nv - 1;
  // Pass 1: the closest segment by squared distance (and the crossing number); its end points are
  // kept per lane, and the closest point's other attributes are derived once, from them.
  vf best = (vf)(MAXFLOAT);
  vi inside = (vi)(0), seg = (vi)(-1);
  vf sAx = zero, sAy = zero, sBx = zero, sBy = zero;  // metric end points
  vf sax = zero, say = zero, sbx = zero, sby = zero;  // real end points
  // The runner-up segment's distance, unit tangent and amplitude: the stroke's tangent and amplitude
  // fields blend the two nearest segments where their distances are close. Otherwise both would
  // jump where the closest segment changes: on the inner side of a bend the two closest points
  // differ, and per-vertex amplitudes made a profile step there (a 60-100 m cliff in the
  // mountain_range example).
  vf second = (vf)(MAXFLOAT), t0x = one, t0y = zero, t1x = one, t1y = zero, a0 = zero, a1 = zero;
  for (int s = 0; s < nseg; ++s) {
    const float4 a4 = verts[v0 + s];
    const float4 b4 = verts[v0 + ((s + 1) % nv)];
    const float Ax = m00 * a4.x + m01 * a4.y, Ay = m10 * a4.x + m11 * a4.y;
    const float Bx = m00 * b4.x + m01 * b4.y, By = m10 * b4.x + m11 * b4.y;
    const float abx = Bx - Ax, aby = By - Ay, l2 = abx * abx + aby * aby;
    const float il2 = l2 > 0.0f ? 1.0f / l2 : 0.0f;
    const vf t = clamp(((Px - Ax) * abx + (Py - Ay) * aby) * il2, 0.0f, 1.0f);
    const vf dx = Px - (Ax + t * abx), dy = Py - (Ay + t * aby);
    const vf d2 = dx * dx + dy * dy;
    const vi m = d2 < best;
    const float2 tr = b4.xy - a4.xy;
    const float trl = length(tr);
    const float2 tu = trl > 0.0f ? tr / trl : (float2)(1.0f, 0.0f);
    const vi m2 = (~m) & (d2 < second);  // new runner-up (not a new best)
    const vf amp = a4.z + t * (b4.z - a4.z);
    second = select(select(second, d2, m2), best, m);
    a1 = select(select(a1, amp, m2), a0, m);
    a0 = select(a0, amp, m);
    t1x = select(select(t1x, (vf)(tu.x), m2), t0x, m);
    t1y = select(select(t1y, (vf)(tu.y), m2), t0y, m);
    t0x = select(t0x, (vf)(tu.x), m);
    t0y = select(t0y, (vf)(tu.y), m);
    best = select(best, d2, m);
    seg = select(seg, (vi)(s), m);
    sAx = select(sAx, (vf)(Ax), m), sAy = select(sAy, (vf)(Ay), m);
    sBx = select(sBx, (vf)(Bx), m), sBy = select(sBy, (vf)(By), m);
    sax = select(sax, (vf)(a4.x), m), say = select(say, (vf)(a4.y), m);
    sbx = select(sbx, (vf)(b4.x), m), sby = select(sby, (vf)(b4.y), m);
    if (closed && a4.y != b4.y) {  // crossing number, real coordinates
      const vi cross = (a4.y <= py) != (b4.y <= py);
      const vf xi = a4.x + (py - a4.y) / (b4.y - a4.y) * (b4.x - a4.x);
      inside ^= cross & (px < xi);
    }
  }
  const vf abx = sBx - sAx, aby = sBy - sAy, l2 = abx * abx + aby * aby;
  const vf traw = select(zero, ((Px - sAx) * abx + (Py - sAy) * aby) / l2, l2 > zero);
  const vf t = clamp(traw, 0.0f, 1.0f);
  const vf dx = Px - (sAx + t * abx), dy = Py - (sAy + t * aby);
  const vf len = sqrt(dx * dx + dy * dy);
  const vf rx = sbx - sax, ry = sby - say;
  // Tangent and amplitude: the closest segment's, blended with the runner-up's by w1 = 1/2 where
  // both are equally near, falling smoothly to 0 where the runner-up is a quarter radius (at least
  // a metre) further.
  {
    const float band = fmax(0.25f * pr[3], 1.0f);
    const vf w1 = 0.5f * (1.0f - smoother_v((sqrt(second) - sqrt(best)) / band));
    const vf bx = (1.0f - w1) * t0x + w1 * t1x, by = (1.0f - w1) * t0y + w1 * t1y;
    const vf bl = sqrt(bx * bx + by * by);
    c.tx = select(t0x, bx / bl, bl > 1e-6f);
    c.ty = select(t0y, by / bl, bl > 1e-6f);
    c.amp = (1.0f - w1) * a0 + w1 * a1;
  }
  const vf qx = sax + t * rx - px, qy = say + t * ry - py;
  const vf ql = sqrt(qx * qx + qy * qy);
  c.ux = select(zero, qx / ql, ql > zero);
  c.uy = select(zero, qy / ql, ql > zero);
  // Side: (-ab.y, ab.x) is "right" (positive); with x east and y south that is the travel
  // direction turned clockwise on a north-up map.
  const vf cr = abx * (Py - sAy) - aby * (Px - sAx);
  const vf side = select(-one, one, cr >= zero);
  const vf al = sqrt(l2);
  const vi lpos = len > zero, apos = al > zero;
  const vf nx = select(select(zero, -aby / al, apos), dx / len, lpos);
  const vf ny = select(select(zero, abx / al, apos), dy / len, lpos);
  c.dist = len;
  vf fx, fy;
  if (closed) {
    // Filled shape: distance 0 inside, sdist negative inside, grad pointing outwards.
    const vf sgn = select(one, -one, inside);
    c.sdist = sgn * len;
    const vf f = select(one, sgn, lpos);
    fx = nx * f, fy = ny * f;
    c.dist = select(len, zero, inside);
  } else {
    c.beyond = select(zero, -traw * al, (seg == 0) & (traw < zero));
    c.beyond = select(c.beyond, (traw - one) * al, (seg == nseg - 1) & (traw > one));
    c.sdist = side * len;
    // d/|d| already points away from the curve; on the curve n is the right normal.
    const vf f = select(one, side, lpos);
    fx = nx * f, fy = ny * f;
  }
  c.gx = m00 * fx + m10 * fy;
  c.gy = m01 * fx + m11 * fy;
  return c;
}

// Weight of primitive i (alpha of the distance over the radius).
vf prim_weight_v(__global const float* pr, const ClosestV* c) {
  const float r = pr[3];
  return r > 0.0f ? alpha_v(c->dist / r) : select((vf)(0.0f), (vf)(1.0f), c->dist <= 0.0f);
}

typedef struct {
  vf a00, a01, a10, a11;
} TensorV;

TensorV tensor_at_v(__global const float* prims, int nprims, __global const float4* verts, vf px, vf py) {
  TensorV A;
  A.a00 = A.a11 = (vf)(1.0f);
  A.a01 = A.a10 = (vf)(0.0f);
  for (int i = 0; i < nprims; ++i) {
    __global const float* pr = prims + 16 * i;
    const ClosestV c = closest_v(pr, verts, px, py);
    const vf w = pr[4] * prim_weight_v(pr, &c);
    if (!any(w != 0.0f)) continue;
    const int kind = (int)pr[5];
    if (kind == TENSOR_SCALE) {
      A.a00 += w;
      A.a11 += w;
    } else if (kind == TENSOR_DIRECTIONAL) {
      // pr[14], pr[15] = cos, sin of 2 angle (computed once on the host): R(2 theta).
      A.a00 += w * pr[14];
      A.a01 += w * pr[15];
      A.a10 += w * pr[15];
      A.a11 -= w * pr[14];
    } else {
      // Aligned with the stroke's tangent or with u(p), rotated by the angle (pr[14], pr[15] = its
      // cos, sin). The traceless direction tensor of a unit u = (cos t, sin t) is
      // [[cos 2t, sin 2t], [sin 2t, -cos 2t]], with cos 2t = ux^2 - uy^2 and sin 2t = 2 ux uy.
      const vf ux0 = kind == TENSOR_TANGENT ? c.tx : c.ux, uy0 = kind == TENSOR_TANGENT ? c.ty : c.uy;
      const float cs = pr[14], sn = pr[15];
      const vf ux = cs * ux0 - sn * uy0, uy = sn * ux0 + cs * uy0;
      const vf c2 = ux * ux - uy * uy, s2 = 2.0f * ux * uy;
      A.a00 += w * c2;
      A.a01 += w * s2;
      A.a10 += w * s2;
      A.a11 -= w * c2;
    }
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
  for (int xs = x0; xs < x0 + bw; xs += VW) {
    const int n = min(VW, x0 + bw - xs);
    float ax[VW], ay[VW], bx[VW], by[VW];
    int any_x = 0, any_y = 0;
    for (int k = 0; k < VW; ++k) {
      const int x = xs + k;
      const size_t o = (size_t)y * W + x;
      const int fx = k < n && x < W - 1, fy = k < n && y < H - 1;
      ax[k] = fx ? sx[o] : 0.0f;
      ay[k] = fx ? other_at_x_face(sy, x, y, W, H) : 0.0f;
      bx[k] = fy ? other_at_y_face(sx, x, y, W, H) : 0.0f;
      by[k] = fy ? sy[o] : 0.0f;
      any_x |= ax[k] != 0.0f || ay[k] != 0.0f;
      any_y |= bx[k] != 0.0f || by[k] != 0.0f;
    }
    // A zero input gives a zero output: skip the tensor (most of a noise layer's box in add mode).
    const vf xv = (float)xs + LANES;
    vf vx = (vf)(0.0f), vy = (vf)(0.0f);
    if (any_x) {
      const TensorV A = tensor_at_v(prims, nprims, verts, (xv + 0.5f) * cx, (vf)((float)y * cy));
      vx = A.a00 * VLOAD(0, ax) + A.a01 * VLOAD(0, ay);
    }
    if (any_y) {
      const TensorV A = tensor_at_v(prims, nprims, verts, xv * cx, (vf)(((float)y + 0.5f) * cy));
      vy = A.a10 * VLOAD(0, bx) + A.a11 * VLOAD(0, by);
    }
    float rx[VW], ry[VW];
    VSTORE(vx, 0, rx);
    VSTORE(vy, 0, ry);
    for (int k = 0; k < n; ++k) {
      const int x = xs + k;
      const size_t o = (size_t)y * W + x;
      if (x < W - 1) dx[o] = add ? dx[o] + rx[k] : rx[k];
      if (y < H - 1) dy[o] = add ? dy[o] + ry[k] : ry[k];
    }
  }
}

// Value of primitive i's profile P_i. pr[12] = profile kind, pr[13] = amplitude scale.
// ROUND: P = a alpha(d/r); SHARP: P = a (1 - d/r)^3; STEP: P = a smoother((s/r + 1)/2) across a
// signed distance s (a fault of throw a); DROP: P = -a smoother(s/r) for s >= 0 (a cliff face, a mesa
// rim). a = pr[13] * the vertex amplitude at the closest point. Open-curve signed profiles taper off
// past the curve's ends (times alpha(beyond/r)) so that a finite fault dies out.
vf profile_value_v(__global const float* pr, const ClosestV* c) {
  const float r = pr[3];
  if (r <= 0.0f) return (vf)(0.0f);
  const int kind = (int)pr[12];
  const vf a = pr[13] * c->amp;
  vf P;
  if (kind == PROFILE_ROUND) {
    P = a * alpha_v(c->dist / r);
  } else if (kind == PROFILE_SHARP) {
    const vf t = fmin(c->dist / r, 1.0f);
    P = a * (1.0f - t) * (1.0f - t) * (1.0f - t);
  } else if (kind == PROFILE_STEP) {
    P = a * smoother_v((c->sdist / r + 1.0f) * 0.5f);
  } else {
    P = -a * smoother_v(c->sdist / r);
  }
  if (kind == PROFILE_STEP || kind == PROFILE_DROP) P = select(P, P * alpha_v(c->beyond / r), c->beyond > 0.0f);
  return P;
}

#define FIELD_WEIGHT 0         // max_i alpha(d_i / r_i): masks for brushes and noise
#define FIELD_WEIGHT_INVERTED 1  // 1 - that
#define FIELD_PROFILE 2        // sum_i P_i: the potential of the profiles

// A per-cell field of the primitives at the cell centres of the box, written on the box only.
__kernel void primitive_field(__global float* out, const int W, const int H, const float cx, const float cy,
                              const int x0, const int y0, const int bw, const int bh,
                              __global const float* prims, const int nprims, __global const float4* verts,
                              const int mode) {
  const int j = get_global_id(0);
  if (j >= bh) return;
  const int y = y0 + j;
  const vf py = (vf)((float)y * cy);
  for (int xs = x0; xs < x0 + bw; xs += VW) {
    const vf px = ((float)xs + LANES) * cx;
    vf v = (vf)(0.0f);
    for (int i = 0; i < nprims; ++i) {
      __global const float* pr = prims + 16 * i;
      const ClosestV c = closest_v(pr, verts, px, py);
      v = mode == FIELD_PROFILE ? v + profile_value_v(pr, &c) : fmax(v, prim_weight_v(pr, &c));
    }
    store_lanes(out + (size_t)y * W + xs, mode == FIELD_WEIGHT_INVERTED ? 1.0f - v : v, min(VW, x0 + bw - xs));
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
