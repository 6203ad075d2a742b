// SPDX-License-Identifier: Apache-2.0
// Gradient noise with analytic derivatives (paper section 4.4: g' = g + grad n needs no finite
// differences of n; the faces combine the cell-centre values and derivatives by the cubic Hermite
// midpoint rule, fourth-order accurate). Perlin-style lattice gradient noise with a quintic fade, fBm and a ridged
// multifractal sum. The amplitude comes from a mask w (cells): the added field is the exact product
// rule grad(A w n) = A (w grad n + n grad w), with grad w the staggered difference of the mask.
// Positions are metres: cell (x, y) is at (x * cx, y * cy).
#pragma OPENCL FP_CONTRACT OFF

#define NOISE_PERLIN 0
#define NOISE_FBM 1
#define NOISE_RIDGED 2

// Each work-item evaluates VW cells of a row in explicit vectors: the octave loop keeps PoCL from
// vectorising across work-items, and the noise sum is the whole cost of a noise layer.
#include "vec8.clh"

vu hash3(vi x, vi y, uint seed) {
  vu h = as_uint8(x) * 0x8da6b343u ^ as_uint8(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

// One of 16 unit directions k pi / 8 chosen by the hash's top four bits: the first quadrant's four
// directions rotated by (k >> 2) quarter turns (selects instead of a table lookup, which would be a
// gather per lane).
void lattice_gradient(vi x, vi y, uint seed, vf* gx, vf* gy) {
  const vi k = as_int8(hash3(x, y, seed) >> 28);
  const vi q = k & 3, quad = k >> 2;
  const vf c = select(select(select((vf)(0.38268343f), (vf)(0.70710678f), q == 2), (vf)(0.92387953f), q == 1),
                      (vf)(1.0f), q == 0);
  const vf s = select(select(select((vf)(0.92387953f), (vf)(0.70710678f), q == 2), (vf)(0.38268343f), q == 1),
                      (vf)(0.0f), q == 0);
  const vi odd = (quad & 1) != 0, neg = quad >= 2;
  const vf rx = select(c, -s, odd), ry = select(s, c, odd);
  *gx = select(rx, -rx, neg);
  *gy = select(ry, -ry, neg);
}

typedef struct {
  vf v, dx, dy;
} NoiseV;

// Value and derivatives of 2-D gradient noise at p (lattice units). Value in about [-0.7, 0.7].
NoiseV perlin(vf px, vf py, uint seed) {
  const vf flx = floor(px), fly = floor(py);
  const vi ix = convert_int8(flx), iy = convert_int8(fly);
  const vf fx = px - flx, fy = py - fly;
  vf gax, gay, gbx, gby, gcx, gcy, gdx, gdy;
  lattice_gradient(ix, iy, seed, &gax, &gay);
  lattice_gradient(ix + 1, iy, seed, &gbx, &gby);
  lattice_gradient(ix, iy + 1, seed, &gcx, &gcy);
  lattice_gradient(ix + 1, iy + 1, seed, &gdx, &gdy);
  const vf va = gax * fx + gay * fy, vb = gbx * (fx - 1.0f) + gby * fy;
  const vf vc = gcx * fx + gcy * (fy - 1.0f), vd = gdx * (fx - 1.0f) + gdy * (fy - 1.0f);
  const vf ux = fx * fx * fx * (fx * (fx * 6.0f - 15.0f) + 10.0f);
  const vf uy = fy * fy * fy * (fy * (fy * 6.0f - 15.0f) + 10.0f);
  const vf dux = 30.0f * fx * fx * (fx * (fx - 2.0f) + 1.0f);
  const vf duy = 30.0f * fy * fy * (fy * (fy - 2.0f) + 1.0f);
  const vf k = va - vb - vc + vd;
  NoiseV o;
  o.v = va + ux * (vb - va) + uy * (vc - va) + ux * uy * k;
  o.dx = gax + ux * (gbx - gax) + uy * (gcx - gax) + ux * uy * (gax - gbx - gcx + gdx) + dux * (uy * k + (vb - va));
  o.dy = gay + ux * (gby - gay) + uy * (gcy - gay) + ux * uy * (gay - gby - gcy + gdy) + duy * (ux * k + (vc - va));
  return o;
}

// Octave k samples the lattice through its own rotation (golden-angle steps, the first octave
// already off the axes) and offset: Perlin noise's spectrum leaks along its lattice axes, and with
// one shared, axis-aligned lattice every octave's leak (and, for ridged noise, every zero of v at a
// lattice point) stacked on the map's rows and columns - east-west and north-south lines in
// hillshade. Rotated octaves spread that leak over many directions (tests/test_noise.cpp measures it).
#define OCTAVE_ANGLE0 0.5f
#define OCTAVE_ANGLE_STEP 2.39996323f
// Ridged noise folds v with a smooth |v| = sqrt(v^2 + e^2) - e: a crest rounded over a few percent
// of a wavelength instead of a kink (whose slope jumps drew knife lines in hillshade).
#define RIDGE_ROUND 0.06f

// Sum of octaves at p (metres); value and derivatives in value units per metre.
NoiseV noise_sum(vf px, vf py, float wavelength, int octaves, float lacunarity, float gain, int type, uint seed) {
  NoiseV acc;
  acc.v = acc.dx = acc.dy = (vf)(0.0f);
  float freq = 1.0f / wavelength, amp = 1.0f;
  const int n = type == NOISE_PERLIN ? 1 : octaves;
  for (int k = 0; k < n; ++k) {
    const float th = OCTAVE_ANGLE0 + OCTAVE_ANGLE_STEP * (float)k;
    const float c = cos(th), s = sin(th);
    const float ox = 0.371f + 17.317f * (float)k, oy = 0.613f - 11.731f * (float)k;
    // q = freq R p + o; dn/dp = freq R^T dn/dq.
    const NoiseV o = perlin(freq * (c * px - s * py) + ox, freq * (s * px + c * py) + oy, seed + 1013u * (uint)k);
    const vf dpx = freq * (c * o.dx + s * o.dy), dpy = freq * (c * o.dy - s * o.dx);
    if (type == NOISE_RIDGED) {
      // (1 - |v|_e)^2: crests where v crosses zero; d = -2 (1 - |v|_e) v / sqrt(v^2 + e^2) dv.
      const vf q = sqrt(o.v * o.v + RIDGE_ROUND * RIDGE_ROUND);
      const vf r = 1.0f + RIDGE_ROUND - q;
      acc.v += amp * (r * r - 0.5f);
      const vf f = amp * (-2.0f * r * o.v / q);
      acc.dx += f * dpx;
      acc.dy += f * dpy;
    } else {
      acc.v += amp * o.v;
      acc.dx += amp * dpx;
      acc.dy += amp * dpy;
    }
    freq *= lacunarity;
    amp *= gain;
  }
  return acc;
}

float mask_at(__global const float* mask, int use_mask, size_t o) { return use_mask ? mask[o] : 1.0f; }
// The mask is only written on the face box [x0, x0 + mw) x [y0, y0 + mh) (the buffer is shared
// scratch, other operations leave their data beyond it); the box extends past the support, so the
// weight outside it is 0.
float mask_in(__global const float* mask, int use_mask, int W, int x, int y, int x0, int y0, int mw, int mh) {
  if (!use_mask) return 1.0f;
  return x >= x0 && y >= y0 && x < x0 + mw && y < y0 + mh ? mask[(size_t)y * W + x] : 0.0f;
}

// Pass 1: noise value and analytic derivatives at the cell centres [x0, x0 + bw) x [y0, y0 + bh)
// (the caller passes the face box plus one column and row), VW cells per work-item. With a mask,
// runs none of whose cells has a face with weight on either side are skipped: noise_faces never
// reads them (a box is mostly outside a curve's or a disc's support).
__kernel void noise_cells(__global float* nv, __global float* nx, __global float* ny, const int W, const int H,
                          const float cx, const float cy, const int x0, const int y0, const int bw, const int bh,
                          __global const float* mask, const int use_mask, const int mw, const int mh,
                          const float wavelength, const int octaves, const float lacunarity, const float gain,
                          const int type, const uint seed) {
  const int i = get_global_id(0) * VW, j = get_global_id(1);
  if (i >= bw || j >= bh) return;
  const int xs = x0 + i, y = y0 + j, n = min(VW, bw - i);
  const size_t o = (size_t)y * W + xs;
  if (use_mask) {
    int needed = 0;
    for (int k = 0; k < n && !needed; ++k) {
      const int x = xs + k;
#define M(xx, yy) mask_in(mask, 1, W, xx, yy, x0, y0, mw, mh)
      needed = M(x, y) != 0.0f || M(x - 1, y) != 0.0f || M(x, y - 1) != 0.0f || M(x + 1, y) != 0.0f || M(x, y + 1) != 0.0f;
#undef M
    }
    if (!needed) return;
  }
  const NoiseV r = noise_sum(((float)xs + LANES) * cx, (vf)((float)y * cy), wavelength, octaves, lacunarity, gain, type, seed);
  store_lanes(nv + o, r.v, n);
  store_lanes(nx + o, r.dx, n);
  store_lanes(ny + o, r.dy, n);
}

// Pass 2: dst (add ? += : =) grad(amplitude * w * n) on the faces of the box. On the face between
// cells a and b (spacing h) the cubic Hermite interpolant of the values and analytic derivatives
// gives n = (na + nb)/2 + h (da - db)/8 and dn = 3 (nb - na)/(2h) - (da + db)/4, fourth-order
// accurate: one noise evaluation per cell instead of one per face.
__kernel void noise_faces(__global float* gx, __global float* gy, __global const float* nv, __global const float* nx,
                          __global const float* ny, const int W, const int H, const float cx, const float cy,
                          const int x0, const int y0, const int bw, const int bh, __global const float* mask,
                          const int use_mask, const float amplitude, const int add) {
  const int i = get_global_id(0), j = get_global_id(1);
  if (i >= bw || j >= bh) return;
  const int x = x0 + i, y = y0 + j;
  const size_t o = (size_t)y * W + x;
  const float wc = mask_at(mask, use_mask, o);
  if (x < W - 1) {
    const float w1 = mask_in(mask, use_mask, W, x + 1, y, x0, y0, bw, bh);
    float v = 0.0f;
    if (wc != 0.0f || w1 != 0.0f) {
      const float na = nv[o], nb = nv[o + 1], da = nx[o], db = nx[o + 1];
      const float n = 0.5f * (na + nb) + cx * (da - db) * 0.125f;
      const float dn = 1.5f * (nb - na) / cx - 0.25f * (da + db);
      v = amplitude * (0.5f * (wc + w1) * dn + n * (w1 - wc) / cx);
    }
    gx[o] = add ? gx[o] + v : v;
  }
  if (y < H - 1) {
    const float w1 = mask_in(mask, use_mask, W, x, y + 1, x0, y0, bw, bh);
    float v = 0.0f;
    if (wc != 0.0f || w1 != 0.0f) {
      const float na = nv[o], nb = nv[o + W], da = ny[o], db = ny[o + W];
      const float n = 0.5f * (na + nb) + cy * (da - db) * 0.125f;
      const float dn = 1.5f * (nb - na) / cy - 0.25f * (da + db);
      v = amplitude * (0.5f * (wc + w1) * dn + n * (w1 - wc) / cy);
    }
    gy[o] = add ? gy[o] + v : v;
  }
}

// Value of the noise at cell centres (for tests and previews): out = amplitude * w * n.
__kernel void noise_value(__global float* out, const int W, const int H, const float cx, const float cy,
                          __global const float* mask, const int use_mask, const float amplitude,
                          const float wavelength, const int octaves, const float lacunarity, const float gain,
                          const int type, const uint seed) {
  const int y = get_global_id(0);
  if (y >= H) return;
  for (int xs = 0; xs < W; xs += VW) {
    const int n = min(VW, W - xs);
    const size_t o = (size_t)y * W + xs;
    const NoiseV r = noise_sum(((float)xs + LANES) * cx, (vf)((float)y * cy), wavelength, octaves, lacunarity, gain, type, seed);
    float v[VW];
    VSTORE(amplitude * r.v, 0, v);
    for (int k = 0; k < n; ++k) out[o + k] = v[k] * mask_at(mask, use_mask, o + k);
  }
}
