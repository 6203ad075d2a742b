// Gradient noise with analytic derivatives (paper section 4.4: g' = g + grad n needs no finite
// differences of n; the faces combine the cell-centre values and derivatives by the cubic Hermite
// midpoint rule, fourth-order accurate). Perlin-style lattice gradient noise with a quintic fade, fBm and a ridged
// multifractal sum. The amplitude comes from a mask w (cells): the added field is the exact product
// rule grad(A w n) = A (w grad n + n grad w), with grad w the staggered difference of the mask.
// Positions are metres: cell (x, y) is at (x * cx, y * cy). One work-item per row of a bounding box.
#pragma OPENCL FP_CONTRACT OFF

#define NOISE_PERLIN 0
#define NOISE_FBM 1
#define NOISE_RIDGED 2

uint hash3(int x, int y, uint seed) {
  uint h = (uint)x * 0x8da6b343u ^ (uint)y * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

// One of 16 unit directions chosen by the hash (a table lookup instead of cos/sin per corner).
__constant float2 kDirections[16] = {
    (float2)(1.0f, 0.0f),           (float2)(0.92387953f, 0.38268343f),  (float2)(0.70710678f, 0.70710678f),
    (float2)(0.38268343f, 0.92387953f), (float2)(0.0f, 1.0f),            (float2)(-0.38268343f, 0.92387953f),
    (float2)(-0.70710678f, 0.70710678f), (float2)(-0.92387953f, 0.38268343f), (float2)(-1.0f, 0.0f),
    (float2)(-0.92387953f, -0.38268343f), (float2)(-0.70710678f, -0.70710678f), (float2)(-0.38268343f, -0.92387953f),
    (float2)(0.0f, -1.0f),          (float2)(0.38268343f, -0.92387953f), (float2)(0.70710678f, -0.70710678f),
    (float2)(0.92387953f, -0.38268343f)};

float2 lattice_gradient(int x, int y, uint seed) { return kDirections[hash3(x, y, seed) >> 28]; }

// (value, d/dx, d/dy) of 2-D gradient noise at p (lattice units). Value in about [-0.7, 0.7].
float3 perlin(float2 p, uint seed) {
  const float2 fl = floor(p);
  const int ix = (int)fl.x, iy = (int)fl.y;
  const float2 f = p - fl;
  const float2 ga = lattice_gradient(ix, iy, seed), gb = lattice_gradient(ix + 1, iy, seed);
  const float2 gc = lattice_gradient(ix, iy + 1, seed), gd = lattice_gradient(ix + 1, iy + 1, seed);
  const float va = dot(ga, f), vb = dot(gb, f - (float2)(1.0f, 0.0f));
  const float vc = dot(gc, f - (float2)(0.0f, 1.0f)), vd = dot(gd, f - (float2)(1.0f, 1.0f));
  const float2 u = f * f * f * (f * (f * 6.0f - 15.0f) + 10.0f);
  const float2 du = 30.0f * f * f * (f * (f - 2.0f) + 1.0f);
  const float k = va - vb - vc + vd;
  const float v = va + u.x * (vb - va) + u.y * (vc - va) + u.x * u.y * k;
  const float2 d = ga + u.x * (gb - ga) + u.y * (gc - ga) + u.x * u.y * (ga - gb - gc + gd) +
                   du * ((float2)(u.y, u.x) * k + (float2)(vb - va, vc - va));
  return (float3)(v, d.x, d.y);
}

// Sum of octaves at p (metres); returns (value, d/dx, d/dy) in value units per metre.
float3 noise_sum(float2 p, float wavelength, int octaves, float lacunarity, float gain, int type, uint seed) {
  float3 acc = (float3)(0.0f, 0.0f, 0.0f);
  float freq = 1.0f / wavelength, amp = 1.0f;
  const int n = type == NOISE_PERLIN ? 1 : octaves;
  for (int k = 0; k < n; ++k) {
    const float3 o = perlin(p * freq, seed + 1013u * (uint)k);
    if (type == NOISE_RIDGED) {
      // (1 - |v|)^2: sharp crests where v crosses zero; d = -2 (1 - |v|) sign(v) dv.
      const float r = 1.0f - fabs(o.x);
      const float s = o.x >= 0.0f ? 1.0f : -1.0f;
      acc.x += amp * (r * r - 0.5f);
      acc.yz += amp * (-2.0f * r * s) * o.yz * freq;
    } else {
      acc.x += amp * o.x;
      acc.yz += amp * o.yz * freq;
    }
    freq *= lacunarity;
    amp *= gain;
  }
  return acc;
}

float mask_at(__global const float* mask, int use_mask, size_t o) { return use_mask ? mask[o] : 1.0f; }

// Pass 1: noise value and analytic derivatives at the cell centres [x0, x0 + bw) x [y0, y0 + bh)
// (the caller passes the face box plus one column and row). With a mask, cells none of whose faces
// has weight on either side are skipped: noise_faces never reads them (a box is mostly outside a
// curve's or a disc's support, and the noise sum is the whole cost).
__kernel void noise_cells(__global float* nv, __global float* nx, __global float* ny, const int W, const int H,
                          const float cx, const float cy, const int x0, const int y0, const int bw, const int bh,
                          __global const float* mask, const int use_mask,
                          const float wavelength, const int octaves, const float lacunarity, const float gain,
                          const int type, const uint seed) {
  const int i = get_global_id(0), j = get_global_id(1);
  if (i >= bw || j >= bh) return;
  const int x = x0 + i, y = y0 + j;
  const size_t o = (size_t)y * W + x;
  if (use_mask && mask[o] == 0.0f && (x == x0 || mask[o - 1] == 0.0f) && (y == y0 || mask[o - W] == 0.0f) &&
      (x + 1 >= W || mask[o + 1] == 0.0f) && (y + 1 >= H || mask[o + W] == 0.0f))
    return;
  const float3 n = noise_sum((float2)((float)x * cx, (float)y * cy), wavelength, octaves, lacunarity, gain, type, seed);
  nv[o] = n.x;
  nx[o] = n.y;
  ny[o] = n.z;
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
    const float w1 = mask_at(mask, use_mask, o + 1);
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
    const float w1 = mask_at(mask, use_mask, o + W);
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
  for (int x = 0; x < W; ++x) {
    const size_t o = (size_t)y * W + x;
    const float3 n = noise_sum((float2)((float)x * cx, (float)y * cy), wavelength, octaves, lacunarity, gain, type, seed);
    out[o] = amplitude * mask_at(mask, use_mask, o) * n.x;
  }
}
