// Per-pixel preview shading (host reference: host/src/render/render.cpp). One work-item per row
// with an x-loop inside (fastest stencil layout on PoCL). Single precision; the host version
// computes in double, and the two agree within one grey level.
#pragma OPENCL FP_CONTRACT OFF

#define MODE_HILLSHADE 0
#define MODE_RELIEF 1
#define MODE_SLOPE 2
#define MODE_SHADED_RELIEF 3

// Neighbour value; outside the grid or nodata -> the centre value (as the host version).
inline float nb(__global const float* z, const int w, const int h, const int x, const int y, const float c) {
  if (x < 0 || y < 0 || x >= w || y >= h) return c;
  const float v = z[(size_t)y * w + x];
  return isnan(v) ? c : v;
}

inline uchar to_byte(const float v) { return (uchar)clamp(floor(v + 0.5f), 0.0f, 255.0f); }

inline void ramp_color(const float v, __global const float* rz, __global const uchar* rgb, const int n,
                       const uint nodata, uchar* out) {
  if (isnan(v)) {
    out[0] = (uchar)(nodata & 255u);
    out[1] = (uchar)((nodata >> 8) & 255u);
    out[2] = (uchar)((nodata >> 16) & 255u);
    return;
  }
  if (v <= rz[0]) {
    out[0] = rgb[0], out[1] = rgb[1], out[2] = rgb[2];
    return;
  }
  for (int k = 1; k < n; ++k) {
    const float a = rz[k - 1], b = rz[k];
    if (v <= b) {
      const float t = b > a ? (v - a) / (b - a) : 1.0f;
      for (int c = 0; c < 3; ++c) {
        const float c0 = (float)rgb[3 * (k - 1) + c], c1 = (float)rgb[3 * k + c];
        out[c] = to_byte(c0 + t * (c1 - c0));
      }
      return;
    }
  }
  out[0] = rgb[3 * (n - 1)], out[1] = rgb[3 * (n - 1) + 1], out[2] = rgb[3 * (n - 1) + 2];
}

// hs: inv_ew, inv_ns (negative for north-up), zs = z_factor / 8, sin_alt254 = 254 sin(alt),
// c_az / s_az = 254 cos|sin(az) cos(alt) zs (gdaldem's constants).
__kernel void render_rows(__global const float* z, const int w, const int h, const int mode,
                          const float inv_ew, const float inv_ns, const float zs, const float sin_alt254,
                          const float c_az, const float s_az, const float slope_zx, const float slope_zy,
                          const float slope_max, const float flat, __global const float* ramp_z,
                          __global const uchar* ramp_rgb, const int nramp, const uint nodata_rgb,
                          __global uchar* out) {
  const int y = get_global_id(0);
  if (y >= h) return;
  for (int x = 0; x < w; ++x) {
    // 64-bit: 3 * cells passes 2^31 from 716 M cells (a 26800^2 grid).
    const size_t o = (size_t)y * w + x;
    const float c = z[o];
    __global uchar* p = out + 3 * o;
    uchar rgb[3] = {0, 0, 0};
    if (mode == MODE_RELIEF || mode == MODE_SHADED_RELIEF) ramp_color(c, ramp_z, ramp_rgb, nramp, nodata_rgb, rgb);
    if (isnan(c)) {
      p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2];
      continue;
    }
    const float a = nb(z, w, h, x - 1, y - 1, c), b = nb(z, w, h, x, y - 1, c), cc = nb(z, w, h, x + 1, y - 1, c);
    const float d = nb(z, w, h, x - 1, y, c), f = nb(z, w, h, x + 1, y, c);
    const float g = nb(z, w, h, x - 1, y + 1, c), hh = nb(z, w, h, x, y + 1, c), i = nb(z, w, h, x + 1, y + 1, c);
    if (mode == MODE_SLOPE) {
      const float gx = ((cc + 2.0f * f + i) - (a + 2.0f * d + g)) * slope_zx;
      const float gy = ((g + 2.0f * hh + i) - (a + 2.0f * b + cc)) * slope_zy;
      const float s = degrees(atan(sqrt(gx * gx + gy * gy)));
      const uchar v = to_byte(255.0f * (1.0f - fmin(s, slope_max) / slope_max));
      p[0] = p[1] = p[2] = v;
      continue;
    }
    uchar shade = 0;
    if (mode == MODE_HILLSHADE || mode == MODE_SHADED_RELIEF) {
      const float gx = ((a + d + d + g) - (cc + f + f + i)) * inv_ew;
      const float gy = ((g + hh + hh + i) - (a + b + b + cc)) * inv_ns;
      const float cang = (sin_alt254 - (gy * c_az - gx * s_az)) / sqrt(1.0f + zs * zs * (gx * gx + gy * gy));
      shade = to_byte(cang <= 0.0f ? 1.0f : 1.0f + cang);
    }
    if (mode == MODE_HILLSHADE) {
      p[0] = p[1] = p[2] = shade;
    } else if (mode == MODE_SHADED_RELIEF) {
      const float k = (0.3f + 0.7f * (float)shade / 255.0f) / (0.3f + 0.7f * flat / 255.0f);
      for (int ch = 0; ch < 3; ++ch) p[ch] = to_byte((float)rgb[ch] * k);
    } else {
      p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2];
    }
  }
}
