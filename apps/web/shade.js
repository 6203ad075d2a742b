// SPDX-License-Identifier: Apache-2.0
// Shading of a float32 terrain for the studio's map: Horn hillshade (light from the north-west, 45
// degrees up) times a colour relief over a fixed elevation range, optional contours, lakes tinted.
const RAMP = [[0, [70, 120, 60]], [0.3, [140, 160, 90]], [0.55, [190, 170, 120]], [0.8, [140, 110, 90]], [1, [250, 250, 250]]];

export function ramp(t, out) {
  t = Math.min(1, Math.max(0, t));
  let i = 1;
  while (i < RAMP.length - 1 && RAMP[i][0] < t) i++;
  const [a, ca] = RAMP[i - 1], [b, cb] = RAMP[i];
  const u = (t - a) / Math.max(1e-9, b - a);
  for (let c = 0; c < 3; c++) out[c] = ca[c] + u * (cb[c] - ca[c]);
}

export function range(z) {
  let lo = Infinity, hi = -Infinity;
  for (const v of z) { if (v < lo) lo = v; if (v > hi) hi = v; }
  return [lo, hi];
}

export function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(Math.max(x, 1e-6))));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

// Water over the shaded ground: pale over shallows, deep blue towards the deepest cell, the bed's
// shading showing through (as terracl edit --preview tints it).
function tintWater(c, k, d, deepest) {
  const u = Math.sqrt(Math.min(1, d / deepest)), a = 0.55 + 0.3 * u;
  const sh = [120, 190, 235], dp = [20, 60, 150];
  for (let j = 0; j < 3; j++) c[j] = (1 - a) * c[j] * k + a * (sh[j] + u * (dp[j] - sh[j]));
}

// t: {w, h, cx, cy, z, water?}; [lo, hi]: the elevations at the two ends of the colour ramp (fixed
// for the session, so that before and after an edit compare by eye); r: the samples to shade
// (inclusive; default all), the picture is of r's size.
export function shade(t, [lo, hi], contours, r = { x0: 0, y0: 0, x1: t.w - 1, y1: t.h - 1 }) {
  const { w, h, z, cx, cy } = t;
  const iw = r.x1 - r.x0 + 1;
  const img = new ImageData(iw, r.y1 - r.y0 + 1);
  const span = Math.max(hi - lo, 1e-6);
  // Horn's hillshade with the sun at azimuth 315 degrees, 45 degrees up, without trigonometry per
  // cell: sin(alt) cos(slope) + cos(alt) sin(slope) cos(az - aspect) = (A + B (p + q)) / sqrt(1 + p^2 + q^2).
  const A = Math.SQRT1_2, B = 0.5;
  const iv = niceStep(span / 15);
  const water = t.water;
  let deepest = 0;
  if (water) for (const d of water) if (d > deepest) deepest = d;
  const c = [0, 0, 0];
  const Z = (x, y) => z[Math.min(h - 1, Math.max(0, y)) * w + Math.min(w - 1, Math.max(0, x))];
  const kx = 1 / (8 * cx), ky = 1 / (8 * cy);
  for (let y = r.y0; y <= r.y1; y++)
    for (let x = r.x0; x <= r.x1; x++) {
      const a = Z(x - 1, y - 1), b = Z(x, y - 1), cc = Z(x + 1, y - 1), d = Z(x - 1, y), f = Z(x + 1, y), g = Z(x - 1, y + 1), hh = Z(x, y + 1), i = Z(x + 1, y + 1);
      const p = ((cc + 2 * f + i) - (a + 2 * d + g)) * kx;
      const q = ((g + 2 * hh + i) - (a + 2 * b + cc)) * ky;
      const hs = Math.max(0, (A + B * (p + q)) / Math.sqrt(1 + p * p + q * q));
      const v = z[y * w + x];
      ramp((v - lo) / span, c);
      let k = 0.35 + 0.65 * hs;
      if (contours && x + 1 < w && y + 1 < h) {
        const band = Math.floor((v - lo) / iv);
        if (band !== Math.floor((z[y * w + x + 1] - lo) / iv) || band !== Math.floor((z[(y + 1) * w + x] - lo) / iv)) k *= 0.45;
      }
      const o = 4 * ((y - r.y0) * iw + x - r.x0);
      if (water && water[y * w + x] > 0) { tintWater(c, k, water[y * w + x], deepest); k = 1; }
      img.data[o] = c[0] * k; img.data[o + 1] = c[1] * k; img.data[o + 2] = c[2] * k; img.data[o + 3] = 255;
    }
  return img;
}
