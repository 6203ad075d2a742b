// SPDX-License-Identifier: Apache-2.0
// Skeleton primitives for gradient-domain authoring (paper section 4.3):
//   * apply_tensor_field: the composite tensor field A(p) = I + sum_i mu_i alpha(d_i/r_i) T_i(p, u(p))
//     applied to a staggered gradient, g' = A g (or g += A delta to orient a noise layer);
//   * primitive_field: the falloff weight max_i alpha(d_i/r_i) (masks for brushes and noise), or the
//     potential sum_i P_i(d_i), a cross-section profile of the distance to a curve (crests, faults,
//     ravines, river banks, rims), whose discrete gradient add_potential_gradient adds to g.
// Positions are metres: cell (x, y) is at (x * cx, y * cy), y growing southwards.
// Each primitive is PRIM_STRIDE floats (layout in host/src/authoring/tensor.cpp); vertices are float4 (x, y, amp,
// arc length from the first vertex).
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
#define PROFILE_V 4
#define PROFILE_U 5

#define PRIM_STRIDE 24

#include "vec8.clh"
#include "launch.clh"

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
  vf amp;         // vertex amplitude interpolated at the closest point (blended, for tensors)
  vf beyond;      // distance past the end of an open polyline (0 along it)
  // Profiles blend the values of the nearest segment (0) and the runner-up (1) with weight w1, so
  // that they are C1 across the medial axis of a bend (the distance itself has a crease there).
  vf w1;
  vf d0, s0, a0, arc0;  // nearest segment: distance, signed distance, amplitude, arc length
  vf d1, s1, a1, arc1;  // runner-up
} ClosestV;

// Weight w1 of the runner-up in the profile blend at a bend, from the squared distances of the nearest
// (best) and the runner-up (second) and the cosine of the angle between their tangents.
vf blend_weight(__global const float* pr, vf best, vf second, vf cosang) {
  const float band = fmax(0.25f * pr[3], 1.0f);
  // The blend measures the gap between the two distances as sqrt(d1^2 + b^2) - sqrt(d0^2 + b^2):
  // about d1 - d0 away from the curve, but smooth where d0 or d1 -> 0 (d1 - d0 has a kink on
  // each segment, which put a crease into the profile along the curve near a bend).
  const float b2 = band * band;
  const vf gap = sqrt(fmin(second, (vf)(1e30f)) + b2) - sqrt(best + b2);
  // Only real bends blend: where the runner-up runs within 15 degrees of the nearest segment (the
  // fine pieces of a smoothed stroke) the crease is small, while blending would pull the profile
  // towards the farther segment's value near every vertex (ripples) and the runner-up switches
  // between the two neighbours mid-segment (steps). Full blending from 35 degrees.
  const vf bend = smoother_v((1.0f - cosang - 0.0341f) / (0.1808f - 0.0341f));
  return select((vf)(0.0f), 0.5f * (1.0f - smoother_v(gap / band)) * bend, second < (vf)(1e30f));
}

// The closest point on piece `seg` of a smoothed stroke (pr[22] != 0, identity metric), the piece
// taken as the cubic Hermite curve between its end points with the vertex tangents (central
// differences of the neighbours, as for the tangent field): consecutive pieces share position and
// tangent direction at their joint, so the distance to the chain is C1 within its reach, where the
// distance to the chords creases on the bisector inside every vertex (a slope jump of about the
// turning angle, 2 sin(2 deg) = 7 % for the spline's pieces). Newton on (c(t) - p) . c'(t) = 0 from the
// chord's projection; the pieces deviate from their chords by a fraction of a cell, so three steps
// converge to float precision.
typedef struct {
  vf d2, t, side;  // squared distance, parameter on the piece, side (+1 right)
  vf cx, cy;       // the foot point
  vf tx, ty;       // the curve's unit tangent there
  vf amp, arc;     // amplitude (cubic Hermite in arc length, as on the chords) and arc length at the foot
} CurveFoot;

CurveFoot hermite_foot(__global const float4* verts, int v0, int nv, vi seg, vf px, vf py) {
  float ax[VW], ay[VW], ex[VW], ey[VW], m0x[VW], m0y[VW], m1x[VW], m1y[VW], aa[VW], ab[VW], ca[VW], cb[VW], za[VW], zb[VW];
  int sg[VW];
  vstore8(seg, 0, sg);
  for (int k = 0; k < VW; ++k) {
    const int s = clamp(sg[k], 0, nv - 2);
    const float4 a4 = verts[v0 + s], b4 = verts[v0 + s + 1];
    const float4 p4 = s > 0 ? verts[v0 + s - 1] : a4;
    const float4 n4 = s + 2 < nv ? verts[v0 + s + 2] : b4;
    const float2 e = b4.xy - a4.xy;
    const float l = length(e);
    const float2 tu = l > 0.0f ? e / l : (float2)(1.0f, 0.0f);
    const float2 ta = b4.xy - p4.xy, tb = n4.xy - a4.xy;
    const float tal = length(ta), tbl = length(tb);
    const float2 ma = (tal > 0.0f ? ta / tal : tu) * l, mb = (tbl > 0.0f ? tb / tbl : tu) * l;
    ax[k] = a4.x, ay[k] = a4.y, ex[k] = e.x, ey[k] = e.y;
    m0x[k] = ma.x, m0y[k] = ma.y, m1x[k] = mb.x, m1y[k] = mb.y;
    aa[k] = a4.z, ab[k] = b4.z, ca[k] = a4.w, cb[k] = b4.w;
    const float la = b4.w - p4.w, lb = n4.w - a4.w, L = b4.w - a4.w;
    const int herm = L > 0.0f && la > 0.0f && lb > 0.0f;
    za[k] = herm ? L * (b4.z - p4.z) / la : b4.z - a4.z;
    zb[k] = herm ? L * (n4.z - a4.z) / lb : b4.z - a4.z;
  }
  const vf Ax = VLOAD(0, ax), Ay = VLOAD(0, ay), Ex = VLOAD(0, ex), Ey = VLOAD(0, ey);
  const vf M0x = VLOAD(0, m0x), M0y = VLOAD(0, m0y), M1x = VLOAD(0, m1x), M1y = VLOAD(0, m1y);
  const vf l2 = Ex * Ex + Ey * Ey;
  vf t = clamp(select((vf)(0.0f), ((px - Ax) * Ex + (py - Ay) * Ey) / l2, l2 > 0.0f), 0.0f, 1.0f);
  vf cx, cy, dx, dy;
  for (int it = 0; it < 4; ++it) {
    const vf h01 = t * t * (3.0f - 2.0f * t), h10 = t * (1.0f - t) * (1.0f - t), h11 = t * t * (t - 1.0f);
    const vf g01 = 6.0f * t * (1.0f - t), g10 = (1.0f - t) * (1.0f - 3.0f * t), g11 = t * (3.0f * t - 2.0f);
    cx = Ax + h01 * Ex + h10 * M0x + h11 * M1x;
    cy = Ay + h01 * Ey + h10 * M0y + h11 * M1y;
    dx = g01 * Ex + g10 * M0x + g11 * M1x;
    dy = g01 * Ey + g10 * M0y + g11 * M1y;
    if (it == 3) break;
    const vf k01 = 6.0f - 12.0f * t, k10 = 6.0f * t - 4.0f, k11 = 6.0f * t - 2.0f;
    const vf ddx = k01 * Ex + k10 * M0x + k11 * M1x, ddy = k01 * Ey + k10 * M0y + k11 * M1y;
    const vf rx = cx - px, ry = cy - py;
    const vf f = rx * dx + ry * dy;
    const vf c2 = dx * dx + dy * dy;
    // Near the centre of a bend tighter than the distance, f' -> 0: keep the step bounded.
    const vf fp = fmax(c2 + rx * ddx + ry * ddy, 0.25f * c2);
    t = clamp(select(t, t - f / fp, fp > 0.0f), 0.0f, 1.0f);
  }
  CurveFoot o;
  const vf qx = px - cx, qy = py - cy;
  o.d2 = qx * qx + qy * qy;
  o.t = t;
  o.cx = cx, o.cy = cy;
  const vf dl = sqrt(dx * dx + dy * dy);
  const vi dpos = dl > 0.0f;
  o.tx = select(select((vf)(1.0f), Ex / sqrt(l2), l2 > 0.0f), dx / dl, dpos);
  o.ty = select(select((vf)(0.0f), Ey / sqrt(l2), l2 > 0.0f), dy / dl, dpos);
  o.side = select((vf)(-1.0f), (vf)(1.0f), o.tx * qy - o.ty * qx >= 0.0f);
  {
    const vf t2 = t * t, t3 = t2 * t;
    o.amp = (2.0f * t3 - 3.0f * t2 + 1.0f) * VLOAD(0, aa) + (t3 - 2.0f * t2 + t) * VLOAD(0, za) +
            (3.0f * t2 - 2.0f * t3) * VLOAD(0, ab) + (t3 - t2) * VLOAD(0, zb);
  }
  o.arc = VLOAD(0, ca) + t * (VLOAD(0, cb) - VLOAD(0, ca));
  return o;
}

// The local minima of the distance to the chords, in stroke order (chord s at step s): a chord whose
// distance is below its predecessor's and not above its successor's. Each minimum keeps `sep`, the
// smaller of the largest (squared) distances between it and the minima before and after it (the
// stroke's ends count as infinitely far), so a minimum about to merge with a maximum (a leg whose
// foot runs off round a bend) has sep -> its distance, and its blend weight fades to zero there.
typedef struct {
  vf pd, runmax, pmd2, pleft;  // previous distance, largest since the pending minimum, pending minimum
  vi desc, pseg, pv;           // previous step went down, pending minimum's chord, pending valid
  vf m0d2, m0sep, m1d2, m1sep; // the nearest two minima
  vi m0seg, m1seg;
} LegMins;

LegMins legmins_init(void) {
  LegMins l;
  l.pd = l.runmax = l.pmd2 = l.pleft = (vf)(MAXFLOAT);
  l.m0d2 = l.m0sep = l.m1d2 = l.m1sep = (vf)(MAXFLOAT);
  l.desc = (vi)(-1);
  l.pv = (vi)(0);
  l.pseg = l.m0seg = l.m1seg = (vi)(-1);
  return l;
}

void legmins_insert(LegMins* l, vi mask, vf d2, vi seg, vf sep) {
  const vi b0 = mask & (d2 < l->m0d2);
  const vi b1 = mask & (~b0) & (d2 < l->m1d2);
  l->m1d2 = select(select(l->m1d2, d2, b1), l->m0d2, b0);
  l->m1seg = select(select(l->m1seg, seg, b1), l->m0seg, b0);
  l->m1sep = select(select(l->m1sep, sep, b1), l->m0sep, b0);
  l->m0d2 = select(l->m0d2, d2, b0);
  l->m0seg = select(l->m0seg, seg, b0);
  l->m0sep = select(l->m0sep, sep, b0);
}

// One chord (s) of the stroke; s = nseg (d2 = MAXFLOAT) closes the sequence.
void legmins_step(LegMins* l, vf d2, int s) {
  const vi det = l->desc & (d2 >= l->pd) & (vi)(s > 0 ? -1 : 0);  // chord s - 1 is a minimum
  legmins_insert(l, det & l->pv, l->pmd2, l->pseg, fmin(l->pleft, l->runmax));
  l->pmd2 = select(l->pmd2, l->pd, det);
  l->pseg = select(l->pseg, (vi)(s - 1), det);
  l->pleft = select(l->pleft, l->runmax, det);
  l->pv |= det;
  l->runmax = select(fmax(l->runmax, d2), d2, det);
  l->desc = select(l->pd > d2, (vi)(-1), (vi)(s == 0 ? -1 : 0));
  l->pd = d2;
}

void legmins_finish(LegMins* l, int nseg) {
  legmins_step(l, (vf)(MAXFLOAT), nseg);
  legmins_insert(l, l->pv, l->pmd2, l->pseg, l->pleft);
}

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
    c.w1 = zero;
    c.d0 = c.d1 = c.dist;
    c.s0 = c.s1 = c.sdist;
    c.a0 = c.a1 = c.amp;
    c.arc0 = c.arc1 = zero;
    return c;
  }
  const int closed = shape == SHAPE_POLYGON;
  const int nseg = closed ? nv : nv - 1;
  c.s0 = one;  // side of the nearest segment so far (a sign)
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
  vf arc0 = zero, arc1 = zero, sg1 = one;  // arc lengths and the runner-up's side
  vf i0x = one, i0y = zero, i1x = one, i1y = zero;  // interpolated vertex tangents
  // Smoothed strokes: the local minima of the chord distance along the stroke, the nearest two with
  // the largest distance separating each from its neighbouring minima (LegMins). Between the legs of
  // a bend tighter than the distance both legs are local minima: their profiles are blended below.
  const int smoothed = pr[22] != 0.0f && !closed && nv >= 3;
  LegMins lm = legmins_init();
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
    if (smoothed) legmins_step(&lm, d2, s);
    const vi m = d2 < best;
    const float2 tr = b4.xy - a4.xy;
    const float trl = length(tr);
    const float2 tu = trl > 0.0f ? tr / trl : (float2)(1.0f, 0.0f);
    // Vertex tangents (central differences of the neighbours) interpolated along the segment: the
    // tangent field is continuous where the nearest segment changes (a smoothed stroke's pieces
    // turn by a few degrees each, and a per-segment tangent made seams in oriented noise there).
    const int has_prev = closed || s > 0, has_next = closed || s + 2 < nv;
    const float4 p4 = has_prev ? verts[v0 + ((s + nv - 1) % nv)] : a4;
    const float4 n4 = has_next ? verts[v0 + ((s + 2) % nv)] : b4;
    const float2 ta = b4.xy - p4.xy, tb = n4.xy - a4.xy;
    const float tal = length(ta), tbl = length(tb);
    const float2 tua = tal > 0.0f ? ta / tal : tu, tub = tbl > 0.0f ? tb / tbl : tu;
    const vf tix = tua.x + t * (tub.x - tua.x), tiy = tua.y + t * (tub.y - tua.y);
    const vi m2 = (~m) & (d2 < second);  // new runner-up (not a new best)
    // Amplitude: the cubic Hermite interpolant in arc length with the neighbours' central-difference
    // slopes (C1 along the stroke). Linear pieces made the slope of a(s) jump at every vertex of a
    // smoothed stroke (every r/8): the profile's along-stroke gradient drew a streak along the
    // normal at each vertex, fans of them across the mountain_range flanks.
    const float la = b4.w - p4.w, lb = n4.w - a4.w, L = b4.w - a4.w;
    // (Closed rings and degenerate pieces: both slopes b - a, which is the linear piece.)
    const int herm = !closed && L > 0.0f && la > 0.0f && lb > 0.0f;
    const float ma = herm ? L * (b4.z - p4.z) / la : b4.z - a4.z, mb = herm ? L * (n4.z - a4.z) / lb : b4.z - a4.z;
    const vf t2 = t * t, t3 = t2 * t;
    const vf amp = (2.0f * t3 - 3.0f * t2 + 1.0f) * a4.z + (t3 - 2.0f * t2 + t) * ma +
                   (3.0f * t2 - 2.0f * t3) * b4.z + (t3 - t2) * mb;
    const vf arc = a4.w + t * (b4.w - a4.w);
    const vf sg = select(-one, one, abx * (Py - Ay) - aby * (Px - Ax) >= 0.0f);
    second = select(select(second, d2, m2), best, m);
    a1 = select(select(a1, amp, m2), a0, m);
    a0 = select(a0, amp, m);
    arc1 = select(select(arc1, arc, m2), arc0, m);
    arc0 = select(arc0, arc, m);
    // Sides (signs of the cross product): a new best demotes the old best together with its side.
    sg1 = select(select(sg1, sg, m2), c.s0, m);
    c.s0 = select(c.s0, sg, m);
    t1x = select(select(t1x, (vf)(tu.x), m2), t0x, m);
    t1y = select(select(t1y, (vf)(tu.y), m2), t0y, m);
    t0x = select(t0x, (vf)(tu.x), m);
    t0y = select(t0y, (vf)(tu.y), m);
    i1x = select(select(i1x, tix, m2), i0x, m);
    i1y = select(select(i1y, tiy, m2), i0y, m);
    i0x = select(i0x, tix, m);
    i0y = select(i0y, tiy, m);
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
  // Tangent (interpolated vertex tangents) and amplitude: the closest segment's, blended with the
  // runner-up's by w1 = 1/2 where both are equally near, falling smoothly to 0 where the runner-up is
  // a quarter radius (at least a metre) further, and only at bends of more than 15 degrees.
  {
    const vf d1 = sqrt(fmin(second, (vf)(1e30f)));
    const vf w1 = blend_weight(pr, best, second, t0x * t1x + t0y * t1y);
    c.w1 = w1;
    c.d1 = d1;
    c.s1 = sg1 * d1;
    c.a0 = a0;
    c.a1 = a1;
    c.arc0 = arc0;
    c.arc1 = arc1;
    const vf bx = (1.0f - w1) * i0x + w1 * i1x, by = (1.0f - w1) * i0y + w1 * i1y;
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
    c.s0 = c.sdist;
    c.s1 = sgn * c.d1;  // filled shapes: the side is inside/outside, the same for both segments
    c.d1 = select(c.d1, zero, inside);
  } else {
    c.beyond = select(zero, -traw * al, (seg == 0) & (traw < zero));
    c.beyond = select(c.beyond, (traw - one) * al, (seg == nseg - 1) & (traw > one));
    c.sdist = side * len;
    c.s0 = c.sdist;
    // d/|d| already points away from the curve; on the curve n is the right normal.
    const vf f = select(one, side, lpos);
    fx = nx * f, fy = ny * f;
    if (pr[22] != 0.0f && nv >= 3) {
      // A smoothed stroke: the distance to the Hermite chain instead of the chords (hermite_foot).
      // Candidates: the nearest chord and its two neighbours. Where the foot moves from one piece to
      // the next these are the pieces on either side of the joint; deep inside a bend the chords'
      // wedges close up (a piece's normals cross at about its turning radius), and the nearest
      // chord can be the neighbour of the piece that holds the foot.
      const CurveFoot f0 = hermite_foot(verts, v0, nv, seg, px, py);
      const CurveFoot fm = hermite_foot(verts, v0, nv, max(seg - 1, (vi)(0)), px, py);
      const CurveFoot fp = hermite_foot(verts, v0, nv, min(seg + 1, (vi)(nseg - 1)), px, py);
      const vi m1 = fm.d2 < f0.d2;
      vf bd2 = select(f0.d2, fm.d2, m1), bside = select(f0.side, fm.side, m1);
      vf btx = select(f0.tx, fm.tx, m1), bty = select(f0.ty, fm.ty, m1);
      vf bcx = select(f0.cx, fm.cx, m1), bcy = select(f0.cy, fm.cy, m1);
      vf bamp = select(f0.amp, fm.amp, m1), barc = select(f0.arc, fm.arc, m1);
      const vi m2 = fp.d2 < bd2;
      bd2 = select(bd2, fp.d2, m2), bside = select(bside, fp.side, m2);
      btx = select(btx, fp.tx, m2), bty = select(bty, fp.ty, m2);
      bcx = select(bcx, fp.cx, m2), bcy = select(bcy, fp.cy, m2);
      bamp = select(bamp, fp.amp, m2), barc = select(barc, fp.arc, m2);
      // The other leg: the runner-up local minimum of the chord distance, refined on the Hermite
      // chain the same way. Between the legs of a bend tighter than the distance (a hairpin), the
      // distance min(d_leg0, d_leg1) creases on the midline and so would the profile; the two legs'
      // profiles are blended there as at a polyline's bend (blend_weight: C1 across the midline),
      // the weight faded by how distinct the runner-up minimum is (its separating maximum over the
      // band), so it reaches zero where that leg's foot runs off round the bend.
      legmins_finish(&lm, nseg);
      const float band = fmax(0.25f * pr[3], 1.0f);
      const float reach = pr[3] + 2.0f * band;
      vi other = (lm.m1seg >= 0) & (abs(lm.m1seg - seg) > 2) & (lm.m1d2 < reach * reach);
      vf od2 = (vf)(MAXFLOAT), oside = one, oamp = zero, oarc = zero;
      if (any(other)) {
        const vi s1 = max(lm.m1seg, (vi)(0));
        const CurveFoot g0 = hermite_foot(verts, v0, nv, s1, px, py);
        const CurveFoot gm = hermite_foot(verts, v0, nv, max(s1 - 1, (vi)(0)), px, py);
        const CurveFoot gp = hermite_foot(verts, v0, nv, min(s1 + 1, (vi)(nseg - 1)), px, py);
        const vi n1 = gm.d2 < g0.d2;
        od2 = select(g0.d2, gm.d2, n1), oside = select(g0.side, gm.side, n1);
        oamp = select(g0.amp, gm.amp, n1), oarc = select(g0.arc, gm.arc, n1);
        const vi n2 = gp.d2 < od2;
        od2 = select(od2, gp.d2, n2), oside = select(oside, gp.side, n2);
        oamp = select(oamp, gp.amp, n2), oarc = select(oarc, gp.arc, n2);
        od2 = select((vf)(MAXFLOAT), od2, other);
      }
      const vf blen = sqrt(bd2), olen = sqrt(fmin(od2, (vf)(1e30f)));
      c.dist = blen;
      c.sdist = bside * blen;
      // The nearer of the two feet carries the profile's main term (the chords and the chain can
      // disagree on which leg is nearer by a fraction of a cell next to the midline).
      const vi swap = od2 < bd2;
      c.d0 = select(blen, olen, swap), c.d1 = select(olen, blen, swap);
      c.s0 = select(bside * blen, oside * olen, swap), c.s1 = select(oside * olen, bside * blen, swap);
      c.a0 = select(bamp, oamp, swap), c.a1 = select(oamp, bamp, swap);
      c.arc0 = select(barc, oarc, swap), c.arc1 = select(oarc, barc, swap);
      const vf sep = sqrt(fmin(lm.m1sep, (vf)(1e30f))) - sqrt(fmin(lm.m1d2, (vf)(1e30f)));
      c.w1 = select(zero, blend_weight(pr, fmin(bd2, od2), fmax(bd2, od2), -one) * smoother_v(sep / band), other);
      c.amp = (1.0f - c.w1) * c.a0 + c.w1 * c.a1;
      c.tx = btx, c.ty = bty;
      const vf qx = bcx - px, qy = bcy - py;
      const vi bpos = blen > 0.0f;
      c.ux = select(zero, qx / blen, bpos);
      c.uy = select(zero, qy / blen, bpos);
      // grad sdist = side (p - foot)/|p - foot|; on the curve, the right normal (-ty, tx).
      fx = select(-bty, -c.ux * bside, bpos);
      fy = select(btx, -c.uy * bside, bpos);
    }
  }
  c.gx = m00 * fx + m10 * fy;
  c.gy = m01 * fx + m11 * fy;
  if (!(pr[22] != 0.0f && !closed && nv >= 3)) c.d0 = c.dist;
  return c;
}

// Weight of primitive i (alpha of the distance over the radius).
vf prim_weight_v(__global const float* pr, const ClosestV* c) {
  const float r = pr[3];
  // A polyline with an inner radius pr[7] (a painted region's band) weighs 1 within it; 0 for strokes.
  const vf d = (int)pr[0] == SHAPE_POLYLINE ? fmax(c->dist - pr[7], (vf)(0.0f)) : c->dist;
  return r > 0.0f ? alpha_v(d / r) : select((vf)(0.0f), (vf)(1.0f), d <= 0.0f);
}

typedef struct {
  vf a00, a01, a10, a11;
} TensorV;

TensorV tensor_at_v(__global const float* prims, int nprims, __global const float4* verts, vf px, vf py) {
  TensorV A;
  A.a00 = A.a11 = (vf)(1.0f);
  A.a01 = A.a10 = (vf)(0.0f);
  for (int i = 0; i < nprims; ++i) {
    __global const float* pr = prims + PRIM_STRIDE * i;
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
  const int j = ROW_ID();
  if (j >= bh) return;
  const int y = y0 + j;
  // FOR_X over chunks of VW cells (the wide shape: one chunk per work-item).
  FOR_X(c, (bw + VW - 1) / VW) {
    const int xs = x0 + c * VW;
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

// Value of primitive i's profile P_i. pr[12] = profile kind, pr[13] = amplitude scale, pr[16] = half
// width f of a flat floor/top, pr[17], pr[18] = taper lengths at the first/last vertex, pr[19] =
// cliff face width as a fraction of r, pr[20] = scree share of a cliff's drop, pr[21] = arc length.
// With u = clamp((d - f) / (r - f), 0, 1) and a = pr[13] * the vertex amplitude at the closest point:
// ROUND: a alpha(u); SHARP: a (1 - u)^3 (u from the distance rounded over pr[23] r on the line); V: a (1 - u)^3 (1 + 3u); U: a (1 - u^4)^2; STEP: a smoother((s/r + 1)/2)
// across a signed distance s (a fault of throw a); DROP: for s >= 0 a cliff face of width c r
// dropping (1 - k) a, then a concave scree apron over [c r, r] dropping k a (C1 at the foot).
// Open-curve signed profiles die out past the curve's ends (times alpha(beyond/r)); other open-curve
// profiles taper to zero towards the ends (amplitude times smoother(arc / taper)), without a cap.
vf profile_shape_v(__global const float* pr, vf d, vf s, vf a) {
  const float r = pr[3];
  const int kind = (int)pr[12];
  const float f = fmin(pr[16], 0.95f * r);
  if (kind == PROFILE_STEP) return a * smoother_v((s / r + 1.0f) * 0.5f);
  if (kind == PROFILE_DROP) {
    // A face over [0, c r] that meets a concave talus apron over [c r, r] with the same slope
    // (tensor.cpp's profile_value says how).
    const float k = clamp(pr[20], 0.0f, 0.95f);
    const float c = clamp(pr[19], 1e-3f, 0.95f);
    const vf x = clamp(s / (c * r), 0.0f, 1.0f);
    const vf v = 1.0f - clamp((s - c * r) / ((1.0f - c) * r), 0.0f, 1.0f);
    const float sigma = fmin(2.0f * k * c / ((1.0f - k) * (1.0f - c)), 3.0f);
    const vf x2 = x * x;
    return -a * ((1.0f - k) * (smoother_v(x) + sigma * x2 * x2 * (x - 1.0f)) + k * (1.0f - v * v));
  }
  const vf u = clamp((d - f) / (r - f), 0.0f, 1.0f);
  if (kind == PROFILE_ROUND) return a * alpha_v(u);
  const vf w = 1.0f - u;
  if (kind == PROFILE_SHARP) {  // the distance rounded over pr[23] r on the crest: no slope kink
    const float rho = fmax(pr[23], 0.0f) * r;
    const vf us = clamp((sqrt(d * d + rho * rho) - rho - f) / (r - f), 0.0f, 1.0f), ws = 1.0f - us;
    return a * ws * ws * ws;
  }
  if (kind == PROFILE_V) return a * w * w * w * (1.0f + 3.0f * u);  // Wendland: a rounded thalweg
  const vf u2 = u * u, q = 1.0f - u2 * u2;
  return a * q * q;
}

vf taper_v(__global const float* pr, vf arc) {
  vf t = (vf)(1.0f);
  if (pr[17] > 0.0f) t = smoother_v(arc / pr[17]);
  if (pr[18] > 0.0f) t *= smoother_v((pr[21] - arc) / pr[18]);
  return t;
}

vf profile_value_v(__global const float* pr, const ClosestV* c) {
  const float r = pr[3];
  if (r <= 0.0f) return (vf)(0.0f);
  const int kind = (int)pr[12];
  const int shape = (int)pr[0];
  vf a0 = pr[13] * c->a0, a1 = pr[13] * c->a1;
  if (shape == SHAPE_POLYLINE && (pr[17] > 0.0f || pr[18] > 0.0f)) {
    a0 *= taper_v(pr, c->arc0);
    a1 *= taper_v(pr, c->arc1);
  }
  vf P = profile_shape_v(pr, c->d0, c->s0, a0);
  if (any(c->w1 > 0.0f)) P = (1.0f - c->w1) * P + c->w1 * profile_shape_v(pr, c->d1, c->s1, a1);
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
  const int j = ROW_ID();
  if (j >= bh) return;
  const int y = y0 + j;
  const vf py = (vf)((float)y * cy);
  FOR_X(c, (bw + VW - 1) / VW) {
    const int xs = x0 + c * VW;
    const vf px = ((float)xs + LANES) * cx;
    vf v = (vf)(0.0f);
    for (int i = 0; i < nprims; ++i) {
      __global const float* pr = prims + PRIM_STRIDE * i;
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
  const int j = ROW_ID();
  if (j >= bh) return;
  const int y = y0 + j;
  const float icx = 1.0f / cx, icy = 1.0f / cy;
  FOR_X(i, bw) {
    const int x = x0 + i;
    const size_t o = (size_t)y * W + x;
    if (x + 1 < x0 + bw) gx[o] += (pot[o + 1] - pot[o]) * icx;
    if (j + 1 < bh) gy[o] += (pot[o + W] - pot[o]) * icy;
  }
}
