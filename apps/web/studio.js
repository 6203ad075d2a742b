// SPDX-License-Identifier: Apache-2.0
// terracl studio page: a map you zoom and pan, strokes you draw, grab and reshape, posted as edit
// operations to the JSON API (docs/studio.md); the terrain re-solves on the server and shows as a
// shaded map and a three.js heightfield. While a stroke is drawn or dragged the page asks for a
// coarse preview (POST /api/preview) at most one request at a time, and draws each as it comes.
import { shade, range } from '/web/shade.js';
import * as G from '/web/geometry.js';
import { init3d, draw3d } from '/web/view3d.js';
import { initExport } from '/web/export.js';

const $ = (id) => document.getElementById(id);
const PREVIEW_MAX = 400;  // samples per side of the overview terrain (1025^2: every 3rd cell)
const DETAIL_MAX = 720;   // samples per side of the zoomed-in window
const DRAG_MAX = 257;     // cells per side of the previews while drawing
const MAX_ZOOM = 64;      // screen pixels per cell

let state = null;    // GET /api/state
let terr = null;     // the overview: {w, h, cx, cy, z, water, step, x0, y0, version}
let detail = null;   // the visible window at up to one sample per screen pixel (zoomed in)
let prev = null;     // a preview while drawing or eroding, drawn instead of the terrain
let colours = null;  // [lo, hi] metres at the ends of the colour ramp (fixed for the session)
let selected = -1;   // selected layer
let drag = null;     // the mouse gesture in progress
let hover = null;    // {px, py} of the cursor over the map
let hoverHandle = null;
let clip = null;     // copy-paste clipboard {source, from}
let eroding = false;
// Figures the latency script reads (scripts/bench-studio-browser.py).
window.__terracl = { latency: [], phases: [], previewFrames: 0, previewMs: [] };
// Where a script point is drawn (canvas px), for tests that grab a vertex.
window.__terraclCanvas = (x, y) => toCanvas(x, y);
// The overview the page holds (tests compare it with the server's terrain after a patch).
window.__terraclOverview = () => ({ w: terr.w, h: terr.h, step: terr.step, version: terr.version, z: Array.from(terr.z) });

// ---- tool parameters (lengths in metres; scaled to the terrain on the first load) ----
// Empty fields ('') are left out of the operation: terracl picks the default from the relief
// around the stroke (docs/authoring.md, "Landform strokes"). Strokes sit relative to the ground.
const TOOLS = {
  select: {},
  // detail: '' (auto: the painted style, else the base DEM's own texture, else the tool's style),
  // procedural, or a style name (docs/authoring.md, "Detail and styles").
  crest: { height: '', radius: '', detail: '' },
  mountain_range: { height: '', radius: '', roughness: 0.5, age: 0.3, spurs: 1, detail: '' },
  river: { depth: '', radius: '', branches: '', detail: '' },
  canyon: { depth: '', radius: '', bands: 4, branches: '', roughness: 0.5, detail: '' },
  ravine: { radius: 0.05, depth: 60 },
  cliff: { drop: '', side: 'right', bands: 3, back: '', detail: '' },
  fault: { radius: 0.03, throw: 40 },
  free_crest: { radius: 0.08, height: 100 },
  peak: { height: '', radius: '', detail: '' },
  volcano: { height: '', radius: '', crater: 0.15, age: 0.3, detail: '' },
  style: { style: 'alpine', radius: 0.06, falloff: 0.02 },
  scale_slopes: { radius: 0.04, factor: 2, falloff: 0.03 },
  noise: { radius: 0.05, amplitude: 20, wavelength: 0.05 },
  freeze: { radius: 0.03 },
  tensor: { radius: 0.05, angle: 45, strength: 0.8 },
  copy_paste: { rotate: 0, height_scale: 1 },
  erode: { radius: 0.1, falloff: 0.03 },
  amplify: { exemplar: '', factor: 4, strength: 1, falloff: 0.03 },
  drainage: { depth: 60, max_depth: 40, threshold: 0.0008, channel_width: 0.006, falloff: 0.03 },
  strata: { radius: 0.1, thickness: 25, soft_thickness: 12, min_slope: 25, falloff: 0.02 },
  lake: { level: '' },  // empty: the basin's spill point; a number: the water surface in metres
};
// The field a brush's strength is ([ and ] change the radius, { and } the strength).
const STRENGTH = { scale_slopes: 'factor', noise: 'amplitude', tensor: 'strength' };
const WORDS = new Set(['exemplar', 'side', 'detail', 'style']);
const LENGTHS = new Set(['radius', 'width', 'falloff', 'wavelength', 'channel_width', 'back']);
const AREAS = new Set(['threshold']);
const CURVES = new Set(['crest', 'river', 'ravine', 'cliff', 'fault', 'free_crest', 'mountain_range', 'canyon']);
const PAINTED = new Set(['scale_slopes', 'noise', 'freeze', 'tensor', 'style']);
const REGIONS = new Set(['copy_paste', 'erode', 'amplify', 'drainage']);
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
  const tool = $('tool').value, t = TOOLS[tool];
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
  $('tool_help').textContent = HELP[tool] || '';
  map.style.cursor = tool === 'select' ? 'default' : 'crosshair';
}
const HELP = {
  select: 'click a stroke to select it; drag a vertex, or the stroke to move it (Shift: rotate); double-click a segment to add a vertex, Delete removes the one under the cursor; Alt+wheel over a vertex changes its height',
  scale_slopes: 'drag to paint, click to stamp; [ ] radius, { } strength',
  noise: 'drag to paint, click to stamp; [ ] radius, { } strength',
  freeze: 'drag to paint, click to stamp; [ ] radius',
  tensor: 'drag to paint along the stroke, click for a disc; [ ] radius, { } strength',
  style: 'paint a style of real detail (alpine, eroded_hills, dissected_plateau, local): the ground under it is re-detailed and later strokes there take it; [ ] radius',
};

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

async function decode(r) {
  const h = (k, d = 0) => (r.headers.has(k) ? +r.headers.get(k) : d);
  return { w: h('X-Width'), h: h('X-Height'), cx: h('X-Cell-X'), cy: h('X-Cell-Y'), step: h('X-Step', 1),
           x0: h('X-X0'), y0: h('X-Y0'), z: new Float32Array(await r.arrayBuffer()), water: null };
}

// A window of the live terrain (and of the lakes' water when the script has a lake).
async function fetchTerrain(max, win = '') {
  const t = await decode(await apiFetch(`/api/terrain.f32?max=${max}${win}`));
  if (state && (state.lakes || []).length) {
    const w = await apiFetch(`/api/water.f32?max=${max}${win}`);
    if (w.ok) {
      const z = new Float32Array(await w.arrayBuffer());
      if (z.length === t.z.length) t.water = z;
    }
  }
  t.version = state ? state.version : 0;
  return t;
}

// A change of the script; `t0` is when the gesture ended (the mouse release), so the status line
// and the latency figures measure release -> painted frame.
async function change(method, path, body, t0 = performance.now()) {
  const s = await api(method, path, body);
  const t1 = performance.now();
  await refresh(s);
  const t2 = performance.now();
  const last = s.last || {};
  const warnings = (last.warnings || []).concat(...(s.lakes || []).map((l) => l.warnings || []));
  const warn = warnings.length ? ' | warning: ' + warnings.join('; ') : '';
  requestAnimationFrame(() => {
    const ms = performance.now() - t0;
    window.__terracl.latency.push(ms);
    window.__terracl.phases.push({ change: t1 - t0, server: last.ms || 0, serverPhases: last.phases_ms || {}, terrain: t2 - t1, paint: t0 + ms - t2 });
    const from = last.mode === 'replay' && last.from > 0 ? ` from layer ${last.from}` : '';
    status(`${last.mode || ''}${from} ${last.ms ? last.ms.toFixed(0) + ' ms solve' : ''}, ${ms.toFixed(0)} ms to the painted map${warn}`);
  });
}

async function refresh(s) {
  state = s || await api('GET', '/api/state');
  if (!scaled) { scaleTools(); showParams(); }
  if (selected >= state.operations.length) selected = -1;
  const last = state.last || {};
  // An append solved locally moved only the cells of its window: patch the overview there.
  if (terr && state.version === terr.version + 1 && last.mode === 'append' && Array.isArray(last.window) &&
      !(state.lakes || []).length && !terr.water) await patchTerrain(last.window);
  else terr = await fetchTerrain(PREVIEW_MAX);
  if (!colours) setColours(terr);
  if (!cam.fitted) fitView();
  prev = null;
  if (detail && detail.version !== state.version) detail = null;
  draw();
  scheduleDetail(0);
  drawLayers();
  $('undo').disabled = !state.can_undo;
  $('redo').disabled = !state.can_redo;
  if (state.warming) status('compiling the device programs in the background...');
  // Tests wait on this: set in the frame after the map's (callbacks run in the order queued).
  const v = state.version;
  requestAnimationFrame(() => { document.body.dataset.version = v; });
}

// The overview's samples inside the cell window [x0, y0, w, h], fetched at the overview's step,
// written into it and shaded again (with a sample of margin: hillshade reads the neighbours).
async function patchTerrain(win) {
  const t = terr, s = t.step;
  if (win.length === 4) {
    const [x0, y0, w, h] = win;
    const jx0 = Math.ceil(x0 / s), jy0 = Math.ceil(y0 / s);
    const jx1 = Math.min(t.w - 1, Math.floor((x0 + w - 1) / s)), jy1 = Math.min(t.h - 1, Math.floor((y0 + h - 1) / s));
    if (jx1 >= jx0 && jy1 >= jy0) {
      const r = await apiFetch(`/api/terrain.f32?step=${s}&x0=${jx0 * s}&y0=${jy0 * s}&x1=${jx1 * s + 1}&y1=${jy1 * s + 1}`);
      const p = await decode(r);
      if (p.w !== jx1 - jx0 + 1 || p.h !== jy1 - jy0 + 1) { terr = await fetchTerrain(PREVIEW_MAX); return; }
      for (let y = 0; y < p.h; y++) t.z.set(p.z.subarray(y * p.w, (y + 1) * p.w), (jy0 + y) * t.w + jx0);
      if (t.canvas) {
        const rr = { x0: Math.max(0, jx0 - 1), y0: Math.max(0, jy0 - 1), x1: Math.min(t.w - 1, jx1 + 1), y1: Math.min(t.h - 1, jy1 + 1) };
        t.canvas.getContext('2d').putImageData(shade(t, colours, $('contours').checked, rr), rr.x0, rr.y0);
      }
    }
  }
  t.version = state.version;
}

// ---- colour scale: fixed at the first terrain, or typed in ----
function setColours(t, force) {
  let [lo, hi] = range(t.z);
  if (!force && hi - lo < 1) { lo -= 100; hi += 900; }  // a flat base: room for what gets drawn
  else { const m = 0.05 * (hi - lo); lo -= m; hi += 2 * m; }
  colours = [Math.floor(lo), Math.ceil(hi)];
  $('c_lo').value = colours[0];
  $('c_hi').value = colours[1];
  for (const x of [terr, detail, prev]) if (x) x.canvas = null;
}
function coloursTyped() {
  const lo = parseFloat($('c_lo').value), hi = parseFloat($('c_hi').value);
  if (!(hi > lo)) { status('colours: the top must be above the bottom', true); return; }
  colours = [lo, hi];
  for (const x of [terr, detail, prev]) if (x) x.canvas = null;
  draw();
}

// ---- the map: camera (screen px = t + s * cell coordinate, cell i spans [i, i + 1)) ----
const map = $('map');
const cam = { s: 1, tx: 0, ty: 0, fitted: false };
const inCells = () => state.units === 'cells';
const UX = () => (inCells() ? 1 : state.cell_x), UY = () => (inCells() ? 1 : state.cell_y);
const round1 = (v) => Math.round(v * 10) / 10;
// a horizontal length in metres (tool fields) -> script units
const L = (m) => (inCells() ? round1(m / state.cell_x) : m);

function fitView() {
  const s = Math.min(map.width / state.width, map.height / state.height);
  Object.assign(cam, { s, tx: (map.width - state.width * s) / 2, ty: (map.height - state.height * s) / 2, fitted: true, fit: s });
}
// canvas px -> script coordinates from the centre of cell (0, 0) (x east, y south)
function toScript(px, py) {
  return [round1(((px - cam.tx) / cam.s - 0.5) * UX()), round1(((py - cam.ty) / cam.s - 0.5) * UY())];
}
function toCanvas(x, y) { return [cam.tx + (x / UX() + 0.5) * cam.s, cam.ty + (y / UY() + 0.5) * cam.s]; }
const lenPx = (len) => (len / UX()) * cam.s;
function evt(e) {
  const r = map.getBoundingClientRect();
  return [(e.clientX - r.left) * map.width / r.width, (e.clientY - r.top) * map.height / r.height];
}
function onMap(x, y) {
  return x >= -0.5 * UX() && y >= -0.5 * UY() && x <= (state.width - 0.5) * UX() && y <= (state.height - 0.5) * UY();
}

function drawTerrain(ctx, t) {
  if (!t.canvas) {
    t.canvas = document.createElement('canvas');
    t.canvas.width = t.w; t.canvas.height = t.h;
    t.canvas.getContext('2d').putImageData(shade(t, colours, $('contours').checked), 0, 0);
  }
  const s = t.step;
  ctx.imageSmoothingEnabled = s * cam.s < 3;  // zoomed in: the cells as squares
  ctx.drawImage(t.canvas, cam.tx + (t.x0 + 0.5 - 0.5 * s) * cam.s, cam.ty + (t.y0 + 0.5 - 0.5 * s) * cam.s,
                t.w * s * cam.s, t.h * s * cam.s);
}

let drawQueued = false;
function draw() {
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(() => { drawQueued = false; drawNow(); });
}
function drawNow() {
  if (!terr || !state) return;
  const ctx = map.getContext('2d');
  ctx.fillStyle = '#000';
  ctx.fillRect(0, 0, map.width, map.height);
  if (prev) drawTerrain(ctx, prev);
  else {
    drawTerrain(ctx, terr);
    if (detail && detail.version === state.version) drawTerrain(ctx, detail);
  }
  drawOps(ctx);
  drawGesture(ctx);
  $('zoom').textContent = `${cam.s >= 1 ? cam.s.toFixed(1) : cam.s.toFixed(2)} px/cell`;
  document.body.dataset.frame = (+(document.body.dataset.frame || 0) + 1).toString();
}

// The 3D view follows the map once the map's frame is out: the mesh update and its software
// rendering must not delay the map (both share the cores with the server).
let timer3d = null;
function schedule3d(t) {
  clearTimeout(timer3d);
  timer3d = setTimeout(() => { if (!drag) draw3d(t, colours); }, 150);
}

// The visible window at one sample per screen pixel, fetched once the view stops moving.
let detailTimer = null, detailBusy = false;
function scheduleDetail(delay = 150) {
  clearTimeout(detailTimer);
  detailTimer = setTimeout(fetchDetail, delay);
}
async function fetchDetail() {
  if (!terr || drag || detailBusy) return;
  // Only when the overview's samples show as blocks of more than 2.5 screen pixels.
  if (terr.step * cam.s <= 2.5) {
    if (detail) { detail = null; window.__terracl.detail = null; draw(); }
    schedule3d(terr);
    return;
  }
  const x0 = Math.max(0, Math.floor(-cam.tx / cam.s)), y0 = Math.max(0, Math.floor(-cam.ty / cam.s));
  const x1 = Math.min(state.width, Math.ceil((map.width - cam.tx) / cam.s)), y1 = Math.min(state.height, Math.ceil((map.height - cam.ty) / cam.s));
  if (x1 - x0 < 2 || y1 - y0 < 2) return;
  detailBusy = true;
  try {
    const t = await fetchTerrain(DETAIL_MAX, `&x0=${x0}&y0=${y0}&x1=${x1}&y1=${y1}`);
    if (state && t.version === state.version) {
      detail = t;
      window.__terracl.detail = { x0: t.x0, y0: t.y0, w: t.w, h: t.h, step: t.step };
      draw();
      schedule3d(detail);
    }
  } finally { detailBusy = false; }
}

// ---- the operations on the map ----
const STYLE = { hard: '#ff5a4a', lower: '#5ad1ff', raise: '#ffd84a', brush: '#c8a2ff', water: '#4aa3ff' };
function opColour(op) {
  if (G.isHard(op)) return STYLE.hard;
  if (['river', 'canyon', 'ravine', 'drainage'].includes(op.op)) return STYLE.lower;
  if (op.op === 'lake') return STYLE.water;
  if (CURVES.has(op.op) || ['peak', 'volcano'].includes(op.op)) return STYLE.raise;
  return STYLE.brush;
}

function pathOf(ctx, pts) {
  ctx.beginPath();
  pts.forEach((p, i) => { const [x, y] = toCanvas(p[0], p[1]); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
}

function drawOp(ctx, op, sel) {
  const col = opColour(op);
  ctx.save();
  ctx.strokeStyle = col;
  ctx.fillStyle = col;
  ctx.lineWidth = sel ? 3 : 1.5;
  ctx.globalAlpha = op.enabled === false ? 0.35 : sel ? 1 : 0.8;
  if (op.enabled === false) ctx.setLineDash([4, 4]);
  const shapes = (o) => {
    if (Array.isArray(o.points) && o.points.length) { pathOf(ctx, o.points); ctx.stroke(); }
    if (Array.isArray(o.path) && o.path.length) {
      // a painted brush: its band, then its centre line
      ctx.save();
      ctx.globalAlpha *= 0.25;
      ctx.lineWidth = Math.max(2, 2 * lenPx(o.radius || op.radius || 0));
      ctx.lineCap = ctx.lineJoin = 'round';
      pathOf(ctx, o.path.length === 1 ? [o.path[0], o.path[0]] : o.path);
      ctx.stroke();
      ctx.restore();
      pathOf(ctx, o.path); ctx.stroke();
    }
    if (Array.isArray(o.polygon) && o.polygon.length) { pathOf(ctx, o.polygon); ctx.closePath(); ctx.stroke(); }
    if (Array.isArray(o.center)) {
      const [x, y] = toCanvas(o.center[0], o.center[1]);
      ctx.beginPath();
      ctx.arc(x, y, Math.max(3, lenPx(o.disc_radius || o.radius || 0)), 0, 2 * Math.PI);
      if (op.op === 'freeze') { ctx.save(); ctx.globalAlpha *= 0.25; ctx.fill(); ctx.restore(); }
      ctx.stroke();
    }
    for (const k of ['seed', 'to'])
      if (Array.isArray(o[k])) { const [x, y] = toCanvas(o[k][0], o[k][1]); ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.fill(); }
    if (Array.isArray(o.from) && o.from.length === 4) {
      const [c0, r0, w, h] = o.from;  // cells of the source
      ctx.strokeRect(cam.tx + c0 * cam.s, cam.ty + r0 * cam.s, w * cam.s, h * cam.s);
    }
  };
  shapes(op);
  (op.primitives || []).forEach(shapes);
  if (sel) {
    // the vertices you can grab, with their heights where the stroke has them
    ctx.setLineDash([]);
    for (const hd of G.handles(op)) {
      const [x, y] = toCanvas(hd.x, hd.y);
      const hot = hoverHandle && hoverHandle.key === hd.key && hoverHandle.i === hd.i;
      ctx.fillStyle = hot ? '#fff' : '#111';
      ctx.strokeStyle = col;
      ctx.lineWidth = 2;
      ctx.fillRect(x - 4, y - 4, 8, 8);
      ctx.strokeRect(x - 4, y - 4, 8, 8);
      if (hd.h !== undefined) { ctx.fillStyle = '#fff'; ctx.fillText(`${round1(hd.h)} m`, x + 7, y - 6); }
    }
  }
  ctx.restore();
}

function drawOps(ctx) {
  if (!state) return;
  const ops = state.operations;
  ops.forEach((op, i) => {
    if (i === selected) return;
    drawOp(ctx, op, false);
  });
  if (selected >= 0 && ops[selected]) drawOp(ctx, drag && drag.op ? drag.op : ops[selected], true);
}

// The gesture in progress (a stroke, a painted band, a rectangle) and the tool's footprint.
function drawGesture(ctx) {
  const tool = $('tool').value, p = TOOLS[tool];
  ctx.save();
  ctx.strokeStyle = '#ff4';
  ctx.lineWidth = 2;
  if (drag && (drag.kind === 'stroke' || drag.kind === 'paint') && drag.pts.length) {
    if (drag.kind === 'paint') {
      ctx.save();
      ctx.globalAlpha = 0.3;
      ctx.lineWidth = Math.max(2, 2 * lenPx(L(p.radius)));
      ctx.lineCap = ctx.lineJoin = 'round';
      pathOf(ctx, drag.pts.length === 1 ? [drag.pts[0], drag.pts[0]] : drag.pts);
      ctx.stroke();
      ctx.restore();
    }
    pathOf(ctx, drag.pts);
    ctx.stroke();
  }
  if (drag && drag.kind === 'rect') {
    const [a, b] = [drag.a, drag.b];
    if (tool === 'copy_paste') ctx.strokeRect(a[0], a[1], b[0] - a[0], b[1] - a[1]);
    else { ctx.beginPath(); ctx.arc((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, Math.hypot(b[0] - a[0], b[1] - a[1]) / 2, 0, 2 * Math.PI); ctx.stroke(); }
  }
  if (clip) { ctx.fillStyle = '#ff4'; ctx.fillText('click to paste', 8, 16); }
  // the footprint under the cursor: a brush's disc, a stroke's half-width when typed in
  if (hover && !drag && tool !== 'select') {
    const r = p.radius > 0 ? p.radius : 0;
    ctx.setLineDash([5, 4]);
    ctx.strokeStyle = 'rgba(255,255,255,0.85)';
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.arc(hover.px, hover.py, r > 0 ? lenPx(L(r)) : 6, 0, 2 * Math.PI);
    ctx.stroke();
    const k = STRENGTH[tool];
    if (r > 0) {
      ctx.fillStyle = '#fff';
      ctx.fillText(`r ${r} m${k ? `, ${k} ${p[k]}` : ''}`, hover.px + 8, hover.py - 8);
    }
  }
  ctx.restore();
}

// The layer under canvas pixel (px, py): the last drawn within 8 px.
function hitTest(px, py) {
  const [x, y] = toScript(px, py), tol = (8 / cam.s) * UX();
  let best = -1, bd = Infinity;
  state.operations.forEach((op, i) => {
    const d = G.distance(op, x, y);
    if (d <= tol && d <= bd) { best = i; bd = d; }
  });
  return best;
}
function handleAt(op, px, py) {
  for (const hd of G.handles(op)) {
    const [x, y] = toCanvas(hd.x, hd.y);
    if (Math.abs(x - px) <= 7 && Math.abs(y - py) <= 7) return hd;
  }
  return null;
}

// ---- operations from gestures ----
// Douglas-Peucker (tolerance in script units) so a stroke posts a handful of vertices.
function simplify(pts, eps) {
  if (pts.length < 3) return pts;
  const [a, b] = [pts[0], pts[pts.length - 1]];
  let best = -1, bi = 0;
  for (let i = 1; i < pts.length - 1; i++) {
    const d = G.segDist(pts[i][0], pts[i][1], a, b)[0];
    if (d > best) { best = d; bi = i; }
  }
  if (best <= eps) return [a, b];
  return simplify(pts.slice(0, bi + 1), eps).slice(0, -1).concat(simplify(pts.slice(bi), eps));
}
const polylineLength = (pts) => pts.reduce((s, p, i) => s + (i ? Math.hypot(p[0] - pts[i - 1][0], p[1] - pts[i - 1][1]) : 0), 0);

// The tool's filled-in fields: lengths scaled to script units, words as they are, numbers if finite.
function withParams(op, p) {
  for (const [k, v] of Object.entries(p)) {
    if (k === 'width' || v === '') continue;
    if (LENGTHS.has(k)) { if (v > 0) op[k] = L(v); } else if (WORDS.has(k)) op[k] = v;
    else if (Number.isFinite(v)) op[k] = v;
  }
  if (p.width > 0) op.width = L(p.width);
  return op;
}

function curveOp(tool, pts) {
  return withParams({ op: tool, points: pts.map(([x, y]) => [round1(x), round1(y)]) }, TOOLS[tool]);
}

// A painted brush: one operation for the whole drag (a path with a radius); a click stamps a disc.
function paintOp(tool, pts) {
  const p = TOOLS[tool], path = pts.map(([x, y]) => [round1(x), round1(y)]);
  if (tool === 'tensor') {
    const prim = { shape: 'polyline', points: path, radius: L(p.radius), tensor: 'directional', angle: p.angle, strength: p.strength };
    return { op: tool, primitives: [path.length === 1 ? { ...prim, shape: 'disc', points: undefined, center: path[0], disc_radius: L(p.radius / 2) } : prim] };
  }
  const op = { op: tool, path, radius: L(p.radius) };
  if (tool === 'scale_slopes') Object.assign(op, { factor: p.factor, falloff: L(p.falloff) });
  if (tool === 'noise') Object.assign(op, { amplitude: p.amplitude, wavelength: L(p.wavelength) });
  if (tool === 'style') Object.assign(op, { style: p.style, falloff: L(p.falloff) });
  return op;
}

function brushOp(tool, c) {
  const p = TOOLS[tool];
  switch (tool) {
    case 'strata': {
      // Layered rock on the steep ground of the disc; the caprock's top is the highest elevation of
      // the preview terrain within the disc, so the beds stack down from there.
      const top = highestWithin(c, L(p.radius));
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

// ---- feedback while drawing: one preview request at a time, the newest gesture wins ----
let previewBusy = false, previewNext = null;
function requestPreview(op, index) {
  previewNext = { op, index };
  if (!previewBusy) runPreview();
}
async function runPreview() {
  const job = previewNext;
  previewNext = null;
  if (!job || !drag) return;
  previewBusy = true;
  try {
    const body = job.index === undefined ? { op: job.op } : { op: job.op, index: job.index };
    const r = await apiFetch(`/api/preview?max=${DRAG_MAX}`, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    if (!r.ok) {
      const j = await r.json();
      if (drag) status('preview: ' + j.error, true);
    } else {
      const t = await decode(r);
      if (drag) {
        prev = t;
        window.__terracl.previewFrames++;
        window.__terracl.previewMs.push(+r.headers.get('X-Preview-Ms'));
        draw();
      }
    }
  } catch (e) { console.warn(e); }
  previewBusy = false;
  if (previewNext && drag) runPreview();
}

// ---- mouse ----
let space = false;
map.addEventListener('contextmenu', (e) => e.preventDefault());
map.addEventListener('mousedown', (e) => {
  if (!state) return;
  // The keys (Delete, [ ], Space) are the map's once it is clicked, not the tool list's.
  if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
  const [px, py] = evt(e);
  if (e.button === 1 || e.button === 2 || space) {  // pan
    e.preventDefault();
    drag = { kind: 'pan', px, py, tx: cam.tx, ty: cam.ty };
    return;
  }
  if (e.button !== 0) return;
  const tool = $('tool').value, at = toScript(px, py);
  if (tool === 'select') {
    const op = state.operations[selected];
    const hd = op && handleAt(op, px, py);
    if (hd) { drag = { kind: 'vertex', hd, op0: op, op, at }; return; }
    const i = hitTest(px, py);
    if (i >= 0) {
      if (i !== selected) selectLayer(i);
      const o = state.operations[i];
      drag = { kind: e.shiftKey ? 'rotate' : 'move', op0: o, op: o, at, c: G.centroid(o) };
    } else if (selected >= 0) selectLayer(-1);
    return;
  }
  if (CURVES.has(tool)) drag = { kind: 'stroke', pts: [at] };
  else if (PAINTED.has(tool)) drag = { kind: 'paint', pts: [at] };
  else if (REGIONS.has(tool) && !(tool === 'copy_paste' && clip)) drag = { kind: 'rect', a: [px, py], b: [px, py] };
  else drag = { kind: 'click' };
});

map.addEventListener('mousemove', (e) => {
  const [px, py] = evt(e);
  hover = { px, py };
  readout(px, py);
  if (drag) return;
  if ($('tool').value === 'select' && selected >= 0 && state.operations[selected]) hoverHandle = handleAt(state.operations[selected], px, py);
  draw();
});
// A gesture follows the mouse beyond the map's edge (a vertex dropped there is refused on release).
window.addEventListener('mousemove', (e) => {
  if (!drag) return;
  const [px, py] = evt(e);
  const tool = $('tool').value, at = toScript(px, py);
  switch (drag.kind) {
    case 'pan':
      cam.tx = drag.tx + px - drag.px; cam.ty = drag.ty + py - drag.py;
      draw();
      return;
    case 'stroke': {
      const l = drag.pts[drag.pts.length - 1];
      if (lenPx(Math.hypot(at[0] - l[0], at[1] - l[1])) > 3) drag.pts.push(at);
      const pts = simplify(drag.pts, (1.5 / cam.s) * UX());
      if (pts.length >= 2 && polylineLength(pts) >= 2 * UX()) requestPreview(curveOp(tool, pts));
      break;
    }
    case 'paint': {
      const l = drag.pts[drag.pts.length - 1];
      if (Math.hypot(at[0] - l[0], at[1] - l[1]) > Math.max(L(TOOLS[tool].radius) / 4, 2 * UX())) {
        drag.pts.push(at);
        requestPreview(paintOp(tool, simplify(drag.pts, (1.5 / cam.s) * UX())));
      }
      break;
    }
    case 'vertex':
      drag.op = G.moveHandle(drag.op0, drag.hd, at[0], at[1]);
      requestPreview(drag.op, selected);
      break;
    case 'move': {
      const dx = at[0] - drag.at[0], dy = at[1] - drag.at[1];
      drag.op = G.transform(drag.op0, ([x, y]) => [round1(x + dx), round1(y + dy)]);
      requestPreview(drag.op, selected);
      break;
    }
    case 'rotate': {
      const c = drag.c;
      if (!c) break;
      const a = Math.atan2(at[1] - c[1], at[0] - c[0]) - Math.atan2(drag.at[1] - c[1], drag.at[0] - c[0]);
      drag.op = G.transform(G.rotate(drag.op0, c, a), ([x, y]) => [round1(x), round1(y)]);
      requestPreview(drag.op, selected);
      break;
    }
    case 'rect':
      drag.b = [px, py];
      break;
  }
  draw();
});

window.addEventListener('mouseup', async (e) => {
  if (!drag) return;
  const t0 = performance.now();
  const d = drag;
  const tool = $('tool').value;
  const [px, py] = evt(e), at = toScript(px, py);
  drag = null;
  const drop = (msg) => { prev = null; draw(); if (msg) status(msg, true); };
  try {
    switch (d.kind) {
      case 'pan':
        scheduleDetail();
        return;
      case 'stroke': {
        const pts = simplify(d.pts, (1.5 / cam.s) * UX());
        if (pts.length < 2 || polylineLength(pts) < 2 * UX()) return drop(`the stroke is too short: drag across the map to draw a ${tool}`);
        if (!pts.every(([x, y]) => onMap(x, y))) return drop('the stroke leaves the map: draw it inside the terrain');
        return await change('POST', '/api/operations', { op: curveOp(tool, pts) }, t0);
      }
      case 'paint': {
        const pts = simplify(d.pts, (1.5 / cam.s) * UX());
        if (!pts.every(([x, y]) => onMap(x, y))) return drop('the brush left the map: paint inside the terrain');
        const op = paintOp(tool, polylineLength(pts) < 0.2 * L(TOOLS[tool].radius) ? [pts[0]] : pts);
        if (tool !== 'tensor' && op.path.length === 1) { op.center = op.path[0]; delete op.path; }
        return await change('POST', '/api/operations', { op }, t0);
      }
      case 'vertex': case 'move': case 'rotate': {
        if (JSON.stringify(d.op) === JSON.stringify(d.op0)) return drop();
        if (!G.handles(d.op).every((h) => onMap(h.x, h.y))) return drop('a vertex left the map: the stroke was put back');
        return await change('PUT', `/api/operations/${selected}`, { op: d.op }, t0);
      }
      case 'rect': {
        if (tool === 'copy_paste') return await copyRect(d.a, d.b);
        const c = toScript((d.a[0] + d.b[0]) / 2, (d.a[1] + d.b[1]) / 2);
        const radius = round1(Math.hypot(d.b[0] - d.a[0], d.b[1] - d.a[1]) / 2 / cam.s * UX());
        if (tool === 'erode') return await erodeBrush(c, radius);
        if (tool === 'amplify') return await amplifyRegion(c, radius, t0);
        if (tool === 'drainage') return await drainageRegion(c, radius, t0);
        return;
      }
      case 'click': {
        if (!onMap(at[0], at[1])) return drop('click on the terrain');
        if (tool === 'copy_paste' && clip) {
          const p = TOOLS.copy_paste;
          const op = { op: 'copy_paste', source: clip.source, from: clip.from, to: at, rotate: p.rotate, height_scale: p.height_scale };
          clip = null;
          return await change('POST', '/api/operations', { op }, t0);
        }
        const op = brushOp(tool, at);
        if (op) return await change('POST', '/api/operations', { op }, t0);
        return drop();
      }
    }
  } catch (err) { console.error(err); prev = null; draw(); }
});

map.addEventListener('dblclick', async (e) => {
  if ($('tool').value !== 'select' || selected < 0) return;
  const [px, py] = evt(e), [x, y] = toScript(px, py), op = state.operations[selected];
  const seg = G.nearestSegment(op, x, y);
  if (!seg || lenPx(seg.d) > 8) return;
  await change('PUT', `/api/operations/${selected}`, { op: G.insertVertex(op, seg.key, seg.i, round1(seg.x), round1(seg.y)) });
});

// Wheel: zoom about the cursor (Alt over a vertex with a height: that height, 10 m a notch).
let heightTimer = null, heightOp = null;
map.addEventListener('wheel', (e) => {
  if (!state) return;
  e.preventDefault();
  const [px, py] = evt(e);
  if (e.altKey && hoverHandle && hoverHandle.h !== undefined && selected >= 0) {
    const base = heightOp || state.operations[selected];
    const hd = G.handles(base).find((h) => h.key === hoverHandle.key && h.i === hoverHandle.i);
    heightOp = G.setHeight(base, hd, round1(hd.h + (e.deltaY < 0 ? 10 : -10)));
    hoverHandle = { ...hoverHandle, h: G.handles(heightOp).find((h) => h.key === hd.key && h.i === hd.i).h };
    state.operations[selected] = heightOp;  // drawn now, recorded when the wheel rests
    draw();
    clearTimeout(heightTimer);
    heightTimer = setTimeout(() => { const op = heightOp; heightOp = null; change('PUT', `/api/operations/${selected}`, { op }); }, 350);
    return;
  }
  const s = Math.min(MAX_ZOOM, Math.max(cam.fit / 2, cam.s * Math.exp(-e.deltaY * 0.0015)));
  cam.tx = px - (px - cam.tx) * s / cam.s;
  cam.ty = py - (py - cam.ty) * s / cam.s;
  cam.s = s;
  draw();
  scheduleDetail();
}, { passive: false });

// Copy: the current terrain is exported into the workspace; the operation pastes from that file,
// so the script replays on the CLI.
async function copyRect(a, b) {
  const cell = (p) => [Math.max(0, Math.min(state.width - 1, Math.floor((p[0] - cam.tx) / cam.s))),
                       Math.max(0, Math.min(state.height - 1, Math.floor((p[1] - cam.ty) / cam.s)))];
  const [c0, r0] = cell([Math.min(a[0], b[0]), Math.min(a[1], b[1])]);
  const [c1, r1] = cell([Math.max(a[0], b[0]), Math.max(a[1], b[1])]);
  if (c1 - c0 < 4 || r1 - r0 < 4) { status('copy: drag a rectangle of at least 5 x 5 cells', true); draw(); return; }
  const source = `clips/clip-${state.version}.tif`;
  status('copying: writing the terrain to ' + source + '...');
  await api('POST', '/api/export', { path: source });
  clip = { source, from: [c0, r0, c1 - c0 + 1, r1 - r0 + 1] };
  draw();
  status('copied; click where to paste');
}

// Amplification of the dragged disc (or of everything for a click): detail finer than `factor`
// cells replaced by sparse-dictionary detail learned from the exemplar (docs/authoring.md).
async function amplifyRegion(c, radius, t0) {
  const p = TOOLS.amplify;
  if (!p.exemplar) { status('amplify: type an exemplar DEM (a file path) in the tool parameters', true); draw(); return; }
  const op = { op: 'amplify', exemplar: p.exemplar, factor: p.factor, strength: p.strength };
  if (radius > 2 * UX()) Object.assign(op, { center: c, radius, falloff: L(p.falloff) });
  status('amplify: learning the dictionary on first use...');
  await change('POST', '/api/operations', { op }, t0);
}

// Stream-power drainage over the dragged disc (or the whole terrain for a click).
async function drainageRegion(c, radius, t0) {
  const p = TOOLS.drainage;
  const op = { op: 'drainage', depth: p.depth, max_depth: p.max_depth, threshold: p.threshold, channel_width: L(p.channel_width) };
  if (radius > 2 * UX()) Object.assign(op, { center: c, radius, falloff: L(p.falloff) });
  await change('POST', '/api/operations', { op }, t0);
}

// The terrain sample under the cursor: the zoomed-in window where it has one, else the overview.
function sampleAt(x, y) {
  for (const t of [prev, detail && state && detail.version === state.version ? detail : null, terr]) {
    if (!t) continue;
    const gx = Math.round((x / UX() - t.x0) / t.step), gy = Math.round((y / UY() - t.y0) / t.step);
    if (gx < 0 || gy < 0 || gx >= t.w || gy >= t.h) continue;
    return { z: t.z[gy * t.w + gx], d: t.water ? t.water[gy * t.w + gx] : 0 };
  }
  return null;
}

// "x, y: z m" under the cursor (script units for x, y, as the tools post them), with the water
// depth over it when a lake covers it.
function readout(px, py) {
  const el = $('readout');
  if (!terr || !state) return;
  const [x, y] = toScript(px, py);
  const s = onMap(x, y) ? sampleAt(x, y) : null;
  if (!s) { el.textContent = ''; return; }
  const u = inCells() ? ' cells' : ' m';
  el.textContent = `${x}, ${y}${u}: ${Number.isFinite(s.z) ? s.z.toFixed(1) + ' m' : 'nodata'}` + (s.d > 0 ? ` (water ${s.d.toFixed(1)} m)` : '');
}
map.addEventListener('mouseleave', () => { $('readout').textContent = ''; hover = null; draw(); });

// The highest elevation of the overview terrain within `r` of script point c.
function highestWithin(c, r) {
  if (!terr) return undefined;
  const gx = c[0] / UX() / terr.step, gy = c[1] / UY() / terr.step;
  const rx = r / UX() / terr.step, ry = r / UY() / terr.step;
  let best;
  for (let y = Math.max(0, Math.floor(gy - ry)); y <= Math.min(terr.h - 1, Math.ceil(gy + ry)); ++y)
    for (let x = Math.max(0, Math.floor(gx - rx)); x <= Math.min(terr.w - 1, Math.ceil(gx + rx)); ++x) {
      if (((x - gx) / rx) ** 2 + ((y - gy) / ry) ** 2 > 1) continue;
      const z = terr.z[y * terr.w + x];
      if (Number.isFinite(z) && (best === undefined || z > best)) best = z;
    }
  return best;
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
async function erodeBrush(c, radius) {
  const p = TOOLS.erode;
  await startErosion({ ...erosionParams(), center: c, radius: Math.max(L(p.radius / 4), radius) || L(p.radius), falloff: L(p.falloff) });
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
    const t = await decode(r);
    frames++; steps += n;
    prev = t;
    draw();
    if (frames % 10 === 0) draw3d(t, colours);
    $('erosion_status').textContent = `${steps} steps, ${(frames * 1000 / (performance.now() - t0)).toFixed(1)} frames/s`;
  }
}
$('erode_all').onclick = () => startErosion(erosionParams());
$('erode_stop').onclick = () => { eroding = false; };
$('erode_commit').onclick = async () => { eroding = false; await change('POST', '/api/erosion/commit', {}); };
$('erode_cancel').onclick = async () => { eroding = false; await change('POST', '/api/erosion/cancel', {}); };

// ---- layers ----
function label(op) {
  const o = { ...op };
  let shape = '';
  if (Array.isArray(op.path)) shape = ` (painted, ${op.path.length} vertices)`;
  else if (Array.isArray(op.points)) shape = ` (${op.points.length} vertices)`;
  if (op.op === 'tensor' && op.primitives) {
    const p = op.primitives[0] || {};
    return `tensor ${p.tensor || ''} ${p.shape || ''} angle=${p.angle ?? 0} strength=${p.strength ?? ''}`.slice(0, 52);
  }
  for (const k of ['op', 'enabled', 'points', 'primitives', 'path', 'polygon', 'center', 'seed', 'to', 'from', 'source']) delete o[k];
  const s = Object.entries(o).filter(([, v]) => typeof v !== 'object').map(([k, v]) => `${k}=${v}`).join(' ');
  return `${op.op}${shape} ${s}`.slice(0, 52);
}

function selectLayer(i) {
  selected = i;
  $('layer_json').value = i >= 0 ? JSON.stringify(state.operations[i], null, 1) : '';
  drawLayers();
  draw();
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
    name.style.borderLeft = `4px solid ${opColour(op)}`;
    name.onclick = () => selectLayer(i);
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
$('contours').onchange = () => { for (const x of [terr, detail, prev]) if (x) x.canvas = null; draw(); };
$('c_lo').onchange = coloursTyped;
$('c_hi').onchange = coloursTyped;
$('c_fit').onclick = () => { setColours(detail && detail.version === state.version ? detail : terr, true); draw(); schedule3d(detail || terr); };
$('fit').onclick = () => { fitView(); detail = null; draw(); scheduleDetail(0); };
$('tool').onchange = () => { hoverHandle = null; showParams(); draw(); };
$('cancel').onclick = cancelRunning;
const typing = (e) => e.target.tagName === 'TEXTAREA' || e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT';
document.addEventListener('keydown', async (e) => {
  if (e.key === ' ' && !typing(e)) { space = true; e.preventDefault(); return; }
  if (e.key === 'Escape') {
    if (drag) { drag = null; prev = null; draw(); return; }
    if (inFlight) { cancelRunning(); return; }
  }
  if (typing(e)) return;
  if (e.ctrlKey || e.metaKey) {
    if (e.key === 'z') { e.preventDefault(); change('POST', '/api/undo'); }
    if (e.key === 'y') { e.preventDefault(); change('POST', '/api/redo'); }
    return;
  }
  const tool = $('tool').value, p = TOOLS[tool];
  if ((e.key === '[' || e.key === ']') && p.radius > 0) { p.radius = Math.round(p.radius * (e.key === ']' ? 1.2 : 1 / 1.2)); showParams(); draw(); }
  const k = STRENGTH[tool];
  if ((e.key === '{' || e.key === '}') && k) { p[k] = round1(p[k] * (e.key === '}' ? 1.2 : 1 / 1.2) * 100) / 100; showParams(); draw(); }
  if ((e.key === 'Delete' || e.key === 'Backspace') && tool === 'select' && selected >= 0) {
    if (hoverHandle && hoverHandle.i >= 0) {
      const op = G.deleteVertex(state.operations[selected], hoverHandle.key, hoverHandle.i);
      if (!op) { status(`${state.operations[selected].op}: this is the fewest vertices it can have`, true); return; }
      hoverHandle = null;
      await change('PUT', `/api/operations/${selected}`, { op });
    } else {
      const i = selected;
      selected = -1;
      await change('DELETE', `/api/operations/${i}`);
    }
  }
});
document.addEventListener('keyup', (e) => { if (e.key === ' ') space = false; });

// Other tabs' edits show up within a second (one shared session).
setInterval(async () => {
  // Not while a change runs: polls would queue behind it and hold the browser's connections.
  if (eroding || drag || inFlight) return;
  const s = await api('GET', '/api/state');
  if (state && (s.version !== state.version || s.warming !== state.warming)) await refresh(s);
}, 1000);

init3d($('view3d'));
initExport({ api, status, getState: () => state });
refresh().then(() => { if (!state.warming) status('ready'); });
