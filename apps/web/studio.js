// terracl studio page: draws tools on a 2D map, posts edit operations to the JSON API
// (docs/studio.md) and shows the re-solved terrain as a shaded map and a three.js heightfield.
// Shading is computed here from the float32 terrain (one request, no server-side rendering).
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';

const $ = (id) => document.getElementById(id);
const PREVIEW_MAX = 513;  // cells per side of the preview terrain
const MESH_MAX = 257;     // cells per side of the 3D mesh

let state = null;    // GET /api/state
let terr = null;     // {w, h, cx, cy, z: Float32Array, water: Float32Array | null}
let selected = -1;   // selected layer
let stroke = null;   // points (canvas px) of the stroke being drawn
let rect = null;     // {x0, y0, x1, y1} canvas px of a region being dragged
let clip = null;     // copy-paste clipboard {source, from}
let eroding = false;

// ---- tool parameters (lengths in metres; scaled to the terrain on the first load) ----
// Empty fields ('') are left out of the operation: terracl picks the default from the relief
// around the stroke (docs/authoring.md, "Landform strokes"). Strokes sit relative to the ground.
const TOOLS = {
  crest: { height: '', radius: '' },
  mountain_range: { height: '', radius: '', roughness: 0.5, age: 0.3, spurs: 1 },
  river: { depth: '', radius: '' },
  canyon: { depth: '', radius: '', bands: 4, roughness: 0.5 },
  ravine: { radius: 0.05, depth: 60 },
  cliff: { drop: '', side: 'right', bands: 3 },
  fault: { radius: 0.03, throw: 40 },
  free_crest: { radius: 0.08, height: 100 },
  peak: { height: '', radius: '' },
  volcano: { height: '', radius: '', crater: 0.15, age: 0.3 },
  scale_slopes: { radius: 0.08, factor: 2, falloff: 0.03 },
  noise: { radius: 0.12, amplitude: 20, wavelength: 0.05 },
  freeze: { radius: 0.05 },
  tensor: { radius: 0.1, angle: 45, strength: 0.8 },
  copy_paste: { rotate: 0, height_scale: 1 },
  erode: { radius: 0.1, falloff: 0.03 },
  amplify: { exemplar: '', factor: 4, strength: 1, falloff: 0.03 },
  drainage: { depth: 60, max_depth: 40, threshold: 0.0008, channel_width: 0.006, falloff: 0.03 },
  strata: { radius: 0.1, thickness: 25, soft_thickness: 12, min_slope: 25, falloff: 0.02 },
  lake: { level: '' },  // empty: the basin's spill point; a number: the water surface in metres
};
// Fields that hold words, not numbers.
const WORDS = new Set(['exemplar', 'side']);
const LENGTHS = new Set(['radius', 'width', 'falloff', 'wavelength', 'channel_width']);
// Areas (m^2) given as a share of the terrain's area: scaled by it on the first load.
const AREAS = new Set(['threshold']);
let scaled = false;

function scaleTools() {
  const ext = state.width * state.cell_x;
  // Amplification borrows the base DEM's own texture unless another exemplar is typed in.
  if (!state.base.startsWith('flat:')) TOOLS.amplify.exemplar = state.base;
  const area = ext * state.height * state.cell_y;
  for (const t of Object.values(TOOLS))
    for (const k of Object.keys(t)) {
      if (LENGTHS.has(k) && t[k] > 0) t[k] = Math.round(t[k] * ext);
      if (AREAS.has(k) && t[k] > 0) t[k] = Math.round(t[k] * area);
    }
  scaled = true;
}

function showParams() {
  const t = TOOLS[$('tool').value];
  const div = $('params');
  div.innerHTML = '';
  for (const [k, v] of Object.entries(t)) {
    const l = document.createElement('label');
    l.textContent = k + (LENGTHS.has(k) || k === 'level' ? ' m' : '');
    const i = document.createElement('input');
    i.value = v;
    i.id = 'p_' + k;
    if (k === 'level') i.placeholder = 'spill';
    else if (v === '') i.placeholder = 'auto';
    i.onchange = () => {
      const w = i.value.trim();
      t[k] = WORDS.has(k) || w === '' ? w : parseFloat(w);
    };
    div.append(l, i);
  }
}

// ---- API ----
// Every API call carries the token the server put in this page (docs/studio.md, "Threat model").
const TOKEN = document.querySelector('meta[name="terracl-token"]').content;
function apiFetch(path, opts = {}) {
  return fetch(path, { ...opts, headers: { ...(opts.headers || {}), 'X-Terracl-Token': TOKEN } });
}
// A change that takes long (a big erosion, a replay) can be stopped: the Cancel button appears.
let inFlight = 0;
async function api(method, path, body) {
  inFlight++;
  const show = setTimeout(() => { $('cancel').hidden = false; }, 700);
  let r;
  try {
    r = await apiFetch(path, { method, headers: { 'Content-Type': 'application/json' }, body: body === undefined ? undefined : JSON.stringify(body) });
  } finally {
    clearTimeout(show);
    if (--inFlight === 0) $('cancel').hidden = true;
  }
  const j = await r.json();
  if (!r.ok) { status('error: ' + j.error, true); throw new Error(j.error); }
  return j;
}
async function cancelRunning() {
  await apiFetch('/api/cancel', { method: 'POST' });
  status('cancelling...');
}

function status(msg, err) {
  $('status').textContent = msg;
  $('status').style.color = err ? '#f88' : '#9fd39f';
}

function decode(r, buf) {
  return { w: +r.headers.get('X-Width'), h: +r.headers.get('X-Height'), cx: +r.headers.get('X-Cell-X'),
           cy: +r.headers.get('X-Cell-Y'), z: new Float32Array(buf) };
}

async function fetchTerrain() {
  const r = await apiFetch('/api/terrain.f32?max=' + PREVIEW_MAX);
  const t = decode(r, await r.arrayBuffer());
  t.water = null;
  // The lakes' water depth, sampled like the terrain; only fetched when the script has a lake.
  if (state && (state.lakes || []).length) {
    const w = await apiFetch('/api/water.f32?max=' + PREVIEW_MAX);
    if (w.ok) {
      const z = new Float32Array(await w.arrayBuffer());
      if (z.length === t.z.length) t.water = z;
    }
  }
  return t;
}

async function change(method, path, body) {
  const t0 = performance.now();
  const s = await api(method, path, body);
  await refresh(s);
  const last = s.last || {};
  // An empty lake is known once it is filled on the new terrain: its warning comes with the lakes.
  const warnings = (last.warnings || []).concat(...(s.lakes || []).map((l) => l.warnings || []));
  const warn = warnings.length ? ' | warning: ' + warnings.join('; ') : '';
  status(`${last.mode || ''} ${last.ms ? last.ms.toFixed(0) + ' ms solve' : ''}, ${(performance.now() - t0).toFixed(0)} ms to preview${warn}`);
}

async function refresh(s) {
  state = s || await api('GET', '/api/state');
  if (!scaled) { scaleTools(); showParams(); }
  terr = await fetchTerrain();
  drawMap();
  draw3d();
  drawLayers();
  $('undo').disabled = !state.can_undo;
  $('redo').disabled = !state.can_redo;
  document.body.dataset.version = state.version;  // tests wait on this
}

// ---- colours and shading ----
const RAMP = [[0, [70, 120, 60]], [0.3, [140, 160, 90]], [0.55, [190, 170, 120]], [0.8, [140, 110, 90]], [1, [250, 250, 250]]];
function ramp(t, out) {
  t = Math.min(1, Math.max(0, t));
  let i = 1;
  while (i < RAMP.length - 1 && RAMP[i][0] < t) i++;
  const [a, ca] = RAMP[i - 1], [b, cb] = RAMP[i];
  const u = (t - a) / Math.max(1e-9, b - a);
  for (let c = 0; c < 3; c++) out[c] = ca[c] + u * (cb[c] - ca[c]);
}

function range(z) {
  let lo = Infinity, hi = -Infinity;
  for (const v of z) { if (v < lo) lo = v; if (v > hi) hi = v; }
  return [lo, hi];
}

// Water over the shaded ground: pale over shallows, deep blue towards the deepest cell, the bed's
// shading showing through (as terracl edit --preview tints it).
function tintWater(c, k, d, deepest) {
  const u = Math.sqrt(Math.min(1, d / deepest)), a = 0.55 + 0.3 * u;
  const sh = [120, 190, 235], dp = [20, 60, 150];
  for (let j = 0; j < 3; j++) c[j] = (1 - a) * c[j] * k + a * (sh[j] + u * (dp[j] - sh[j]));
}

// Horn hillshade (light from the north-west, 45 degrees up) times the colour relief.
function shade(t) {
  const { w, h, z, cx, cy } = t;
  const img = new ImageData(w, h);
  const [lo, hi] = range(z);
  const span = Math.max(hi - lo, 1e-6);
  const az = (360 - 315 + 90) * Math.PI / 180, alt = 45 * Math.PI / 180;
  const contours = $('contours').checked;
  const iv = niceStep(span / 15);
  const water = t.water;
  let deepest = 0;
  if (water) for (const d of water) if (d > deepest) deepest = d;
  const c = [0, 0, 0];
  const Z = (x, y) => z[Math.min(h - 1, Math.max(0, y)) * w + Math.min(w - 1, Math.max(0, x))];
  for (let y = 0; y < h; y++)
    for (let x = 0; x < w; x++) {
      const a = Z(x - 1, y - 1), b = Z(x, y - 1), cc = Z(x + 1, y - 1), d = Z(x - 1, y), f = Z(x + 1, y), g = Z(x - 1, y + 1), hh = Z(x, y + 1), i = Z(x + 1, y + 1);
      const dzdx = ((cc + 2 * f + i) - (a + 2 * d + g)) / (8 * cx);
      const dzdy = ((g + 2 * hh + i) - (a + 2 * b + cc)) / (8 * cy);
      const slope = Math.atan(Math.hypot(dzdx, dzdy));
      const aspect = Math.atan2(dzdy, -dzdx);
      let hs = Math.sin(alt) * Math.cos(slope) + Math.cos(alt) * Math.sin(slope) * Math.cos(az - aspect);
      hs = Math.max(0, hs);
      const v = z[y * w + x];
      ramp((v - lo) / span, c);
      let k = 0.35 + 0.65 * hs;
      if (contours && x + 1 < w && y + 1 < h) {
        const q = Math.floor((v - lo) / iv);
        if (q !== Math.floor((z[y * w + x + 1] - lo) / iv) || q !== Math.floor((z[(y + 1) * w + x] - lo) / iv)) k *= 0.45;
      }
      const o = 4 * (y * w + x);
      if (water && water[y * w + x] > 0) { tintWater(c, k, water[y * w + x], deepest); k = 1; }
      img.data[o] = c[0] * k; img.data[o + 1] = c[1] * k; img.data[o + 2] = c[2] * k; img.data[o + 3] = 255;
    }
  return img;
}

function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(Math.max(x, 1e-6))));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

// ---- 2D map ----
const map = $('map');
const off = document.createElement('canvas');
let view = { ox: 0, oy: 0, sw: 1, sh: 1 };

function drawMap(t = terr) {
  if (!t) return;
  off.width = t.w; off.height = t.h;
  off.getContext('2d').putImageData(shade(t), 0, 0);
  const ctx = map.getContext('2d');
  ctx.fillStyle = '#000';
  ctx.fillRect(0, 0, map.width, map.height);
  const ax = t.w * t.cx, ay = t.h * t.cy, s = Math.min(map.width / ax, map.height / ay);
  view = { sw: ax * s, sh: ay * s, ox: (map.width - ax * s) / 2, oy: (map.height - ay * s) / 2 };
  ctx.imageSmoothingEnabled = true;
  ctx.drawImage(off, view.ox, view.oy, view.sw, view.sh);
  overlay(ctx);
}

function overlay(ctx) {
  ctx.strokeStyle = '#ff4';
  ctx.lineWidth = 2;
  if (stroke && stroke.length > 1) {
    ctx.beginPath();
    ctx.moveTo(stroke[0][0], stroke[0][1]);
    for (const p of stroke) ctx.lineTo(p[0], p[1]);
    ctx.stroke();
  }
  if (rect) ctx.strokeRect(rect.x0, rect.y0, rect.x1 - rect.x0, rect.y1 - rect.y0);
  if (clip) { ctx.fillStyle = '#ff4'; ctx.fillText('click to paste', 8, 16); }
}

// canvas pixel -> script coordinates from the centre of cell (0, 0) (x east, y south): metres, or
// cells when the loaded script says "units": "cells"
const inCells = () => state.units === 'cells';
function toMetres(px, py) {
  const fx = (px - view.ox) / view.sw, fy = (py - view.oy) / view.sh;
  const cx = inCells() ? 1 : state.cell_x, cy = inCells() ? 1 : state.cell_y;
  return [round1((fx * state.width - 0.5) * cx), round1((fy * state.height - 0.5) * cy)];
}
// a horizontal length in metres (tool fields) -> script units
const L = (m) => (inCells() ? round1(m / state.cell_x) : m);
const round1 = (v) => Math.round(v * 10) / 10;
function toCell(px, py) {
  const fx = (px - view.ox) / view.sw, fy = (py - view.oy) / view.sh;
  return [Math.max(0, Math.min(state.width - 1, Math.round(fx * state.width - 0.5))),
          Math.max(0, Math.min(state.height - 1, Math.round(fy * state.height - 0.5)))];
}
function evt(e) {
  const r = map.getBoundingClientRect();
  return [(e.clientX - r.left) * map.width / r.width, (e.clientY - r.top) * map.height / r.height];
}

// Douglas-Peucker in canvas px so a stroke posts a handful of vertices.
function simplify(pts, eps) {
  if (pts.length < 3) return pts;
  const [a, b] = [pts[0], pts[pts.length - 1]];
  let best = -1, bi = 0;
  for (let i = 1; i < pts.length - 1; i++) {
    const p = pts[i], dx = b[0] - a[0], dy = b[1] - a[1], L = Math.hypot(dx, dy) || 1;
    const d = Math.abs(dy * p[0] - dx * p[1] + b[0] * a[1] - b[1] * a[0]) / L;
    if (d > best) { best = d; bi = i; }
  }
  if (best <= eps) return [a, b];
  return simplify(pts.slice(0, bi + 1), eps).slice(0, -1).concat(simplify(pts.slice(bi), eps));
}

const CURVES = new Set(['crest', 'river', 'ravine', 'cliff', 'fault', 'free_crest', 'mountain_range', 'canyon']);
const REGIONS = new Set(['copy_paste', 'erode', 'amplify', 'drainage']);

function num(k, v) { return Number.isFinite(v) ? v : undefined; }

// The tool's filled-in fields: lengths scaled to script units, words as they are, numbers if finite.
function withParams(op, p) {
  for (const [k, v] of Object.entries(p)) {
    if (k === 'width' || v === '') continue;
    if (LENGTHS.has(k)) { if (v > 0) op[k] = L(v); } else if (WORDS.has(k)) op[k] = v;
    else if (num(k, v) !== undefined) op[k] = v;
  }
  if (p.width > 0) op.width = L(p.width);
  return op;
}

function curveOp(tool, pts) {
  const p = TOOLS[tool];
  const op = { op: tool, points: pts.map(([x, y]) => toMetres(x, y)) };
  return withParams(op, p);
}

function brushOp(tool, px, py) {
  const p = TOOLS[tool];
  const c = toMetres(px, py);
  switch (tool) {
    case 'scale_slopes': return { op: tool, center: c, radius: L(p.radius), factor: p.factor, falloff: L(p.falloff) };
    case 'noise': return { op: tool, center: c, radius: L(p.radius), amplitude: p.amplitude, wavelength: L(p.wavelength) };
    case 'freeze': return { op: tool, center: c, radius: L(p.radius) };
    case 'tensor': return { op: tool, primitives: [{ shape: 'disc', center: c, disc_radius: L(p.radius / 2), radius: L(p.radius),
                                                     tensor: 'directional', angle: p.angle, strength: p.strength }] };
    case 'strata': {
      // Layered rock on the steep ground of the disc; the caprock's top is the highest elevation of
      // the preview terrain within the disc, so the beds stack down from there.
      const top = highestWithin(px, py, p.radius);
      if (top === undefined) return null;
      return { op: tool, center: c, radius: L(p.radius), falloff: L(p.falloff), top: round1(top),
               thickness: p.thickness, soft_thickness: p.soft_thickness, min_slope: p.min_slope };
    }
    case 'lake': {
      // Click = the seed; the level field empty (or "spill") fills the basin to its spill point.
      const op = { op: 'lake', seed: c };
      const lv = parseFloat(p.level);
      if (Number.isFinite(lv)) op.level = lv;
      return op;
    }
    case 'peak': case 'volcano': return withParams({ op: tool, center: c }, p);
  }
  return null;
}

map.addEventListener('mousedown', (e) => {
  if (!state) return;
  const [x, y] = evt(e);
  const tool = $('tool').value;
  if (CURVES.has(tool)) stroke = [[x, y]];
  else if (REGIONS.has(tool) && !(tool === 'copy_paste' && clip)) rect = { x0: x, y0: y, x1: x, y1: y };
});
map.addEventListener('mousemove', (e) => {
  const [x, y] = evt(e);
  readout(x, y);
  if (stroke) {
    const l = stroke[stroke.length - 1];
    if (Math.hypot(x - l[0], y - l[1]) > 3) stroke.push([x, y]);
    drawMap();
  } else if (rect) {
    rect.x1 = x; rect.y1 = y;
    drawMap();
  }
});
map.addEventListener('mouseup', async (e) => {
  const [x, y] = evt(e);
  const tool = $('tool').value;
  try {
    if (stroke) {
      const pts = simplify(stroke, 1.5);
      stroke = null;
      if (pts.length >= 2) await change('POST', '/api/operations', { op: curveOp(tool, pts) });
      else drawMap();
    } else if (rect) {
      const r = rect;
      rect = null;
      if (tool === 'copy_paste') await copyRect(r);
      else if (tool === 'erode') await erodeBrush(r);
      else if (tool === 'amplify') await amplifyRegion(r);
      else if (tool === 'drainage') await drainageRegion(r);
    } else if (tool === 'copy_paste' && clip) {
      const p = TOOLS.copy_paste;
      const op = { op: 'copy_paste', source: clip.source, from: clip.from, to: toMetres(x, y), rotate: p.rotate, height_scale: p.height_scale };
      clip = null;
      await change('POST', '/api/operations', { op });
    } else {
      const op = brushOp(tool, x, y);
      if (op) await change('POST', '/api/operations', { op });
    }
  } catch (err) { console.error(err); drawMap(); }
});

// Copy: the current terrain is exported into the workspace; the operation pastes from that file,
// so the script replays on the CLI.
async function copyRect(r) {
  const [c0, r0] = toCell(Math.min(r.x0, r.x1), Math.min(r.y0, r.y1));
  const [c1, r1] = toCell(Math.max(r.x0, r.x1), Math.max(r.y0, r.y1));
  if (c1 - c0 < 4 || r1 - r0 < 4) { drawMap(); return; }
  const source = `clips/clip-${state.version}.tif`;
  await api('POST', '/api/export', { path: source });
  clip = { source, from: [c0, r0, c1 - c0 + 1, r1 - r0 + 1] };
  drawMap();
  status('copied; click where to paste');
}

// Amplification of the dragged region (or of everything for a click): detail finer than `factor`
// cells replaced by sparse-dictionary detail learned from the exemplar (docs/authoring.md).
async function amplifyRegion(r) {
  const p = TOOLS.amplify;
  if (!p.exemplar) { status('amplify: type an exemplar DEM (a file path) in the tool parameters', true); drawMap(); return; }
  const [x0, y0] = toMetres(r.x0, r.y0), [x1, y1] = toMetres(r.x1, r.y1);
  const radius = Math.hypot(x1 - x0, y1 - y0) / 2;
  const op = { op: 'amplify', exemplar: p.exemplar, factor: p.factor, strength: p.strength };
  if (radius > 2 * state.cell_x) Object.assign(op, { center: [round1((x0 + x1) / 2), round1((y0 + y1) / 2)], radius: round1(radius), falloff: L(p.falloff) });
  status('amplify: learning the dictionary on first use...');
  await change('POST', '/api/operations', { op });
}

// "x, y: z m" of the preview terrain under the cursor (script units for x, y, as the tools post
// them), with the water depth over it when a lake covers it.
function readout(px, py) {
  const el = $('readout');
  if (!terr || !state) return;
  const fx = (px - view.ox) / view.sw, fy = (py - view.oy) / view.sh;
  if (fx < 0 || fy < 0 || fx > 1 || fy > 1) { el.textContent = ''; return; }
  const gx = Math.max(0, Math.min(terr.w - 1, Math.round(fx * terr.w - 0.5)));
  const gy = Math.max(0, Math.min(terr.h - 1, Math.round(fy * terr.h - 0.5)));
  const z = terr.z[gy * terr.w + gx], d = terr.water ? terr.water[gy * terr.w + gx] : 0;
  const [mx, my] = toMetres(px, py), u = inCells() ? ' cells' : ' m';
  el.textContent = `${mx}, ${my}${u}: ${Number.isFinite(z) ? z.toFixed(1) + ' m' : 'nodata'}` + (d > 0 ? ` (water ${d.toFixed(1)} m)` : '');
}
map.addEventListener('mouseleave', () => { $('readout').textContent = ''; });

// The highest elevation of the preview terrain within radius_m metres of canvas pixel (px, py).
function highestWithin(px, py, radius_m) {
  if (!terr) return undefined;
  const fx = (px - view.ox) / view.sw, fy = (py - view.oy) / view.sh;
  const gx = fx * terr.w - 0.5, gy = fy * terr.h - 0.5;
  const rx = radius_m / (state.width * state.cell_x) * terr.w, ry = radius_m / (state.height * state.cell_y) * terr.h;
  let best;
  for (let y = Math.max(0, Math.floor(gy - ry)); y <= Math.min(terr.h - 1, Math.ceil(gy + ry)); ++y)
    for (let x = Math.max(0, Math.floor(gx - rx)); x <= Math.min(terr.w - 1, Math.ceil(gx + rx)); ++x) {
      if (((x - gx) / rx) ** 2 + ((y - gy) / ry) ** 2 > 1) continue;
      const z = terr.z[y * terr.w + x];
      if (Number.isFinite(z) && (best === undefined || z > best)) best = z;
    }
  return best;
}

// Stream-power drainage over the dragged disc (or the whole terrain for a click): gullies and
// valleys carved along the terrain's own flow (docs/authoring.md "Drainage").
async function drainageRegion(r) {
  const p = TOOLS.drainage;
  const [x0, y0] = toMetres(r.x0, r.y0), [x1, y1] = toMetres(r.x1, r.y1);
  const radius = Math.hypot(x1 - x0, y1 - y0) / 2;
  const op = { op: 'drainage', depth: p.depth, max_depth: p.max_depth, threshold: p.threshold, channel_width: L(p.channel_width) };
  if (radius > 2 * state.cell_x) Object.assign(op, { center: [round1((x0 + x1) / 2), round1((y0 + y1) / 2)], radius: round1(radius), falloff: L(p.falloff) });
  await change('POST', '/api/operations', { op });
}

// ---- erosion ----
// The look's preset, with rain and capacity only when typed in (they override the preset).
function erosionParams() {
  const p = { preset: $('e_preset').value };
  for (const k of ['rain', 'capacity']) {
    const v = parseFloat($('e_' + k).value);
    if (Number.isFinite(v)) p[k] = v;
  }
  return p;
}
async function erodeBrush(r) {
  const [x0, y0] = toMetres(r.x0, r.y0), [x1, y1] = toMetres(r.x1, r.y1);
  const p = TOOLS.erode;
  const radius = Math.max(L(p.radius / 4), Math.hypot(x1 - x0, y1 - y0) / 2) || L(p.radius);
  await startErosion({ ...erosionParams(), center: [round1((x0 + x1) / 2), round1((y0 + y1) / 2)], radius: round1(radius), falloff: L(p.falloff) });
}
async function startErosion(params) {
  await api('POST', '/api/erosion/start', params);
  eroding = true;
  let frames = 0, steps = 0;
  const t0 = performance.now();
  const n = Math.max(1, parseInt($('e_steps').value) || 1);
  while (eroding) {
    const r = await apiFetch(`/api/erosion/step?steps=${n}&max=${PREVIEW_MAX}`, { method: 'POST' });
    if (!r.ok) { eroding = false; status((await r.json()).error, true); break; }
    const t = decode(r, await r.arrayBuffer());
    frames++; steps += n;
    drawMap(t);
    if (frames % 10 === 0) draw3d(t);
    $('erosion_status').textContent = `${steps} steps, ${(frames * 1000 / (performance.now() - t0)).toFixed(1)} frames/s`;
  }
}
$('erode_all').onclick = () => startErosion(erosionParams());
$('erode_stop').onclick = () => { eroding = false; };
$('erode_commit').onclick = async () => { eroding = false; await change('POST', '/api/erosion/commit', {}); };
$('erode_cancel').onclick = async () => { eroding = false; await change('POST', '/api/erosion/cancel', {}); };

// ---- 3D view ----
let renderer = null, scene, camera, controls, mesh = null, waterMesh = null;
function init3d() {
  const el = $('view3d');
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (e) {
    el.textContent = '3D view unavailable (no WebGL)';
    return;
  }
  renderer.setSize(el.clientWidth, el.clientHeight);
  el.appendChild(renderer.domElement);
  scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1b2633);
  camera = new THREE.PerspectiveCamera(45, el.clientWidth / el.clientHeight, 1, 1e7);
  controls = new OrbitControls(camera, renderer.domElement);
  scene.add(new THREE.AmbientLight(0xffffff, 0.35));
  const sun = new THREE.DirectionalLight(0xffffff, 0.8);
  sun.position.set(-1, 1, -1);
  scene.add(sun);
  // Render on demand (camera moved, terrain changed): a continuous loop would take the CPU that
  // the device (PoCL) needs.
  controls.addEventListener('change', render3d);
}
let pending = false;
function render3d() {
  if (pending || !renderer) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; renderer.render(scene, camera); });
}

function draw3d(t = terr) {
  if (!renderer || !t) return;
  const step = Math.max(1, Math.ceil(Math.max(t.w, t.h) / MESH_MAX));
  const w = Math.floor((t.w - 1) / step) + 1, h = Math.floor((t.h - 1) / step) + 1;
  const ax = (w - 1) * step * t.cx, ay = (h - 1) * step * t.cy;
  if (!mesh || mesh.userData.w !== w || mesh.userData.h !== h) {
    if (mesh) { scene.remove(mesh); mesh.geometry.dispose(); }
    const g = new THREE.PlaneBufferGeometry(ax, ay, w - 1, h - 1);
    g.rotateX(-Math.PI / 2);  // rows run +z (south), columns +x (east), elevation +y
    g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(w * h * 3), 3));
    mesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors }));
    mesh.userData = { w, h };
    scene.add(mesh);
    camera.position.set(0, Math.max(ax, ay) * 0.8, Math.max(ax, ay) * 1.05);
    controls.target.set(0, 0, 0);
  }
  const [lo, hi] = range(t.z);
  const span = Math.max(hi - lo, 1e-6), mid = (lo + hi) / 2;
  const pos = mesh.geometry.attributes.position, col = mesh.geometry.attributes.color;
  const c = [0, 0, 0];
  for (let y = 0; y < h; y++)
    for (let x = 0; x < w; x++) {
      const v = t.z[y * step * t.w + x * step], i = y * w + x;
      pos.setY(i, v - mid);
      ramp((v - lo) / span, c);
      col.setXYZ(i, c[0] / 255, c[1] / 255, c[2] / 255);
    }
  pos.needsUpdate = true;
  col.needsUpdate = true;
  mesh.geometry.computeVertexNormals();
  drawWater3d(t, w, h, step, ax, ay, mid, span);
  controls.update();
  render3d();
}

// The lakes as one semi-transparent surface over the same grid, made of the cells that touch water
// only: wet vertices at the water surface, the shore's dry ones under the ground, so the surface
// meets the terrain near the shore (a whole grid of hidden triangles flickered through the terrain).
function drawWater3d(t, w, h, step, ax, ay, mid, span) {
  if (!t.water) { if (waterMesh) waterMesh.visible = false; return; }
  if (!waterMesh || waterMesh.userData.w !== w || waterMesh.userData.h !== h) {
    if (waterMesh) { scene.remove(waterMesh); waterMesh.geometry.dispose(); }
    const g = new THREE.PlaneBufferGeometry(ax, ay, w - 1, h - 1);
    g.rotateX(-Math.PI / 2);
    waterMesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ color: 0x2f6fc0, transparent: true, opacity: 0.65, depthWrite: false }));
    waterMesh.userData = { w, h };
    scene.add(waterMesh);
  }
  const pos = waterMesh.geometry.attributes.position, below = 0.02 * span;
  const wet = new Uint8Array(w * h);
  for (let y = 0; y < h; y++)
    for (let x = 0; x < w; x++) {
      const k = y * step * t.w + x * step, d = t.water[k];
      wet[y * w + x] = d > 0 ? 1 : 0;
      pos.setY(y * w + x, d > 0 ? t.z[k] + d - mid : t.z[k] - mid - below);
    }
  const index = [];
  for (let y = 0; y + 1 < h; y++)
    for (let x = 0; x + 1 < w; x++) {
      const a = y * w + x, b = a + w, c = b + 1, d = a + 1;  // PlaneBufferGeometry's quad and winding
      if (wet[a] | wet[b] | wet[c] | wet[d]) index.push(a, b, d, b, c, d);
    }
  waterMesh.geometry.setIndex(index);
  pos.needsUpdate = true;
  waterMesh.geometry.computeVertexNormals();
  waterMesh.visible = true;
}

// ---- layers ----
function label(op) {
  const o = { ...op };
  delete o.op; delete o.enabled; delete o.points; delete o.primitives;
  const s = Object.entries(o).filter(([, v]) => typeof v !== 'object').map(([k, v]) => `${k}=${v}`).join(' ');
  return `${op.op} ${s}`.slice(0, 48);
}

function drawLayers() {
  const ol = $('layer_list');
  ol.innerHTML = '';
  state.operations.forEach((op, i) => {
    const li = document.createElement('li');
    if (op.enabled === false) li.classList.add('off');
    if (i === selected) li.classList.add('sel');
    const vis = document.createElement('input');
    vis.type = 'checkbox';
    vis.checked = op.enabled !== false;
    vis.title = 'visible';
    vis.onchange = () => change('POST', `/api/operations/${i}/visible`, { visible: vis.checked });
    const name = document.createElement('span');
    name.textContent = ' ' + label(op) + ' ';
    name.onclick = () => { selected = i; $('layer_json').value = JSON.stringify(op, null, 1); drawLayers(); };
    const btn = (txt, title, f) => { const b = document.createElement('button'); b.textContent = txt; b.title = title; b.onclick = f; return b; };
    li.append(vis, name,
      btn('\u2191', 'move up', () => i > 0 && change('POST', `/api/operations/${i}/move`, { to: i - 1 })),
      btn('\u2193', 'move down', () => i + 1 < state.operations.length && change('POST', `/api/operations/${i}/move`, { to: i + 1 })),
      btn('\u2715', 'delete', () => { selected = -1; change('DELETE', `/api/operations/${i}`); }));
    ol.append(li);
  });
}

$('layer_apply').onclick = () => {
  if (selected < 0) return;
  let op;
  try { op = JSON.parse($('layer_json').value); } catch (e) { status('layer JSON: ' + e.message, true); return; }
  change('PUT', `/api/operations/${selected}`, { op });
};

// ---- header ----
$('undo').onclick = () => change('POST', '/api/undo');
$('redo').onclick = () => change('POST', '/api/redo');
$('save').onclick = async () => { await api('POST', '/api/save', { path: $('file').value }); status('saved ' + $('file').value); };
$('load').onclick = () => change('POST', '/api/load', { path: $('file').value });
$('export').onclick = async () => {
  const name = $('file').value.replace(/\.json$/, '.tif');
  const r = await api('POST', '/api/export', { path: name });
  status('wrote ' + r.written);
};
$('contours').onchange = () => drawMap();
$('tool').onchange = showParams;
$('cancel').onclick = cancelRunning;
document.addEventListener('keydown', (e) => {
  if (e.key === 'Escape' && inFlight) { cancelRunning(); return; }
  if (!(e.ctrlKey || e.metaKey) || e.target.tagName === 'TEXTAREA' || e.target.tagName === 'INPUT') return;
  if (e.key === 'z') { e.preventDefault(); change('POST', '/api/undo'); }
  if (e.key === 'y') { e.preventDefault(); change('POST', '/api/redo'); }
});
// Other tabs' edits show up within a second (one shared session).
setInterval(async () => {
  // Not while a change runs: polls would queue behind it and hold the browser's connections.
  if (eroding || stroke || rect || inFlight) return;
  const s = await api('GET', '/api/state');
  if (state && s.version !== state.version) await refresh(s);
}, 1000);

init3d();
refresh().then(() => status('ready'));
