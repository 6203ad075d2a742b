// SPDX-License-Identifier: Apache-2.0
// The geometry of edit operations in script coordinates (docs/authoring.md): what the studio draws
// on the map, hit-tests, and moves when a stroke is grabbed. Every function returns a new operation
// and leaves its argument alone, so a drag can be dropped without a trace.

// Keys holding a list of vertices [x, y] or [x, y, h], with the fewest vertices each may keep.
const LISTS = { points: 2, path: 1, polygon: 3 };
// Keys holding one point [x, y].
const SINGLE = ['center', 'seed', 'to'];

const copy = (op) => JSON.parse(JSON.stringify(op));

// Every handle of an operation: {key, i (-1 for a single point), x, y, h (a per-vertex height or
// undefined)}; tensor primitives' centres and points come as `primitives.N.center` / `.points`.
export function handles(op) {
  const out = [];
  const add = (obj, prefix) => {
    for (const k of Object.keys(LISTS))
      if (Array.isArray(obj[k]))
        obj[k].forEach((p, i) => { if (Array.isArray(p) && p.length >= 2) out.push({ key: prefix + k, i, x: p[0], y: p[1], h: p[2] }); });
    for (const k of SINGLE)
      if (Array.isArray(obj[k]) && obj[k].length >= 2) out.push({ key: prefix + k, i: -1, x: obj[k][0], y: obj[k][1] });
  };
  add(op, '');
  (op.primitives || []).forEach((p, j) => add(p, `primitives.${j}.`));
  return out;
}

// The object and key a handle's key names (`primitives.2.points` -> op.primitives[2], 'points').
function owner(op, key) {
  const parts = key.split('.');
  let o = op;
  while (parts.length > 1) o = o[parts.shift()];
  return [o, parts[0]];
}

export function moveHandle(op, hd, x, y) {
  const o2 = copy(op);
  const [o, k] = owner(o2, hd.key);
  const p = hd.i < 0 ? o[k] : o[k][hd.i];
  p[0] = x; p[1] = y;
  return o2;
}

export function setHeight(op, hd, h) {
  const o2 = copy(op);
  const [o, k] = owner(o2, hd.key);
  if (hd.i >= 0 && o[k][hd.i].length >= 3) o[k][hd.i][2] = h;
  return o2;
}

// Applies f([x, y]) -> [x, y] to every handle of the operation.
export function transform(op, f) {
  let o2 = op;
  for (const hd of handles(op)) { const [x, y] = f([hd.x, hd.y]); o2 = moveHandle(o2, hd, x, y); }
  return o2;
}

export function centroid(op) {
  const hs = handles(op);
  if (!hs.length) return null;
  return [hs.reduce((s, h) => s + h.x, 0) / hs.length, hs.reduce((s, h) => s + h.y, 0) / hs.length];
}

export function rotate(op, [cx, cy], a) {
  const c = Math.cos(a), s = Math.sin(a);
  return transform(op, ([x, y]) => [cx + c * (x - cx) - s * (y - cy), cy + s * (x - cx) + c * (y - cy)]);
}

// Inserts a vertex after vertex i of list `key` (a copy of its neighbour's height, if any).
export function insertVertex(op, key, i, x, y) {
  const o2 = copy(op);
  const [o, k] = owner(o2, key);
  const v = [x, y];
  if (o[k][i].length >= 3) v.push(o[k][i][2]);
  o[k].splice(i + 1, 0, v);
  return o2;
}

// Removes vertex i of list `key`; null when the list would keep fewer vertices than it needs.
export function deleteVertex(op, key, i) {
  const [o0, k] = owner(op, key);
  if (!(k in LISTS) || o0[k].length - 1 < LISTS[k]) return null;
  const o2 = copy(op);
  const [o] = owner(o2, key);
  o[k].splice(i, 1);
  return o2;
}

export function segDist(px, py, a, b) {
  const dx = b[0] - a[0], dy = b[1] - a[1], L2 = dx * dx + dy * dy;
  const t = L2 > 0 ? Math.max(0, Math.min(1, ((px - a[0]) * dx + (py - a[1]) * dy) / L2)) : 0;
  return [Math.hypot(px - a[0] - t * dx, py - a[1] - t * dy), t];
}

// The nearest segment of a vertex list to (x, y): {key, i (segment from vertex i), d, x, y}.
export function nearestSegment(op, x, y) {
  let best = null;
  for (const hd of handles(op)) {
    if (hd.i < 0) continue;
    const [o, k] = owner(op, hd.key);
    const list = o[k];
    if (hd.i + 1 >= list.length) continue;
    const [d, t] = segDist(x, y, list[hd.i], list[hd.i + 1]);
    if (!best || d < best.d)
      best = { key: hd.key, i: hd.i, d, x: list[hd.i][0] + t * (list[hd.i + 1][0] - list[hd.i][0]), y: list[hd.i][1] + t * (list[hd.i + 1][1] - list[hd.i][1]) };
  }
  return best;
}

function insidePolygon(x, y, poly) {
  let inside = false;
  for (let i = 0, j = poly.length - 1; i < poly.length; j = i++) {
    const [xi, yi] = poly[i], [xj, yj] = poly[j];
    if ((yi > y) !== (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

// How far (script units) (x, y) is from the operation's drawn shape: 0 inside a disc, a painted
// path's band or a polygon; Infinity for operations without geometry (the whole map).
export function distance(op, x, y) {
  let d = Infinity;
  const r = op.radius || 0;
  const lists = (o) => {
    for (const k of ['points', 'path']) {
      const l = o[k];
      if (!Array.isArray(l)) continue;
      if (l.length === 1) d = Math.min(d, Math.max(0, Math.hypot(x - l[0][0], y - l[0][1]) - (k === 'path' ? r : 0)));
      for (let i = 0; i + 1 < l.length; i++) d = Math.min(d, Math.max(0, segDist(x, y, l[i], l[i + 1])[0] - (k === 'path' ? r : 0)));
    }
    if (Array.isArray(o.polygon) && o.polygon.length >= 3) d = Math.min(d, insidePolygon(x, y, o.polygon) ? 0 : Infinity);
    if (Array.isArray(o.center)) {
      const rr = o.disc_radius || o.radius || 0;
      d = Math.min(d, Math.max(0, Math.hypot(x - o.center[0], y - o.center[1]) - rr));
    }
    for (const k of ['seed', 'to']) if (Array.isArray(o[k])) d = Math.min(d, Math.hypot(x - o[k][0], y - o[k][1]));
  };
  lists(op);
  (op.primitives || []).forEach(lists);
  return d;
}

// Whether an operation pins elevations (hard constraints the solve keeps exactly).
export function isHard(op) {
  if (op.op === 'freeze' || op.op === 'fit') return true;
  return op.elevation !== undefined && ['crest', 'river', 'cliff', 'ravine', 'free_crest', 'point', 'elevation'].includes(op.op);
}
