// SPDX-License-Identifier: Apache-2.0
// The studio's 3D view: a three.js heightfield of what the map shows (the zoomed-in window when
// there is one, else the whole terrain), at most MESH_MAX vertices a side, coloured with the map's
// fixed colour scale; lakes as a semi-transparent surface. Renders on demand only: a continuous loop
// would take the CPU that the device (PoCL) needs.
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';
import { ramp } from '/web/shade.js';

const MESH_MAX = 257;
let renderer = null, scene, camera, controls, mesh = null, waterMesh = null;

export function init3d(el) {
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
  controls.addEventListener('change', render3d);
}

let pending = false;
function render3d() {
  if (pending || !renderer) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; renderer.render(scene, camera); });
}

// t: {w, h, cx, cy, z, water, x0, y0, step}; colours: [lo, hi] of the map's ramp.
export function draw3d(t, colours) {
  if (!renderer || !t) return;
  const step = Math.max(1, Math.ceil(Math.max(t.w, t.h) / MESH_MAX));
  const w = Math.floor((t.w - 1) / step) + 1, h = Math.floor((t.h - 1) / step) + 1;
  const ax = (w - 1) * step * t.cx, ay = (h - 1) * step * t.cy;
  const key = `${w}x${h}@${ax}x${ay}:${t.x0},${t.y0}`;
  if (!mesh || mesh.userData.key !== key) {
    if (mesh) { scene.remove(mesh); mesh.geometry.dispose(); }
    const g = new THREE.PlaneBufferGeometry(ax, ay, w - 1, h - 1);
    g.rotateX(-Math.PI / 2);  // rows run +z (south), columns +x (east), elevation +y
    g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(w * h * 3), 3));
    mesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors }));
    mesh.userData = { key, w, h };
    scene.add(mesh);
    camera.position.set(0, Math.max(ax, ay) * 0.8, Math.max(ax, ay) * 1.05);
    controls.target.set(0, 0, 0);
  }
  const [lo, hi] = colours;
  const span = Math.max(hi - lo, 1e-6);
  let zlo = Infinity, zhi = -Infinity;  // the mesh is centred on its own relief, coloured on the map's scale
  for (const v of t.z) { if (v < zlo) zlo = v; if (v > zhi) zhi = v; }
  const mid = (zlo + zhi) / 2;
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
// meets the terrain near the shore.
function drawWater3d(t, w, h, step, ax, ay, mid, span) {
  if (!t.water) { if (waterMesh) waterMesh.visible = false; return; }
  if (!waterMesh || waterMesh.userData.key !== mesh.userData.key) {
    if (waterMesh) { scene.remove(waterMesh); waterMesh.geometry.dispose(); }
    const g = new THREE.PlaneBufferGeometry(ax, ay, w - 1, h - 1);
    g.rotateX(-Math.PI / 2);
    waterMesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ color: 0x2f6fc0, transparent: true, opacity: 0.65, depthWrite: false }));
    waterMesh.userData = { key: mesh.userData.key };
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
