// The 3-D map (three.js): floors stacked with the vertical axis exaggerated as in the paper's
// Fig. 1, nodes coloured by session, odometry and loop-closure edges told apart, newly
// accepted closures highlighted, the robot's pose and its recent trail. Orbit, pan and zoom
// with the mouse (OrbitControls); a top view per floor; a click on a node selects it.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { PlanLayer } from './plan_layer.js';

const SESSION_COLOURS = [0x5fb3ff, 0x7ddc6f, 0xe36bd8, 0xf2d64b, 0x59e0c8, 0xb48cff, 0xff5f7a,
                         0xc0c0c0, 0x3fd17f, 0xffa0e0];
const SESSION_RGB = SESSION_COLOURS.map((hex) => { const c = new THREE.Color(hex); return [c.r, c.g, c.b]; });
const TRAIL = 600;           // poses kept in the trail
const NEW_CLOSURE_MS = 6000; // how long a new closure stays highlighted
// The trail is broken where the pose jumps (a new session starts at its own origin; a
// re-localisation moves the robot) rather than drawn as a line across the map.
const TRAIL_BREAK_M = 5;

export class MapScene {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    // Software WebGL (SwiftShader, llvmpipe: a machine or a browser test without a GPU) draws a
    // frame in tens to hundreds of milliseconds of CPU: no antialiasing and at most 4 frames a
    // second there, so the page keeps up with the stream.
    this.software = /swiftshader|llvmpipe|software/i.test(rendererName(this.renderer));
    if (this.software) {
      this.renderer.dispose();
      this.renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
    }
    this.minFrameMs = this.software ? 250 : 0;
    this.lastFrame = 0;
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(0x101317);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.1, 1e6);
    this.camera.up.set(0, 0, 1);  // world z is up
    this.camera.position.set(-40, -60, 50);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = true;
    // Drawn only when something changed (a message, the mouse): a still map costs no CPU.
    this.dirty = true;
    this.controls.addEventListener('change', () => { this.dirty = true; });
    // The view follows the map's extent as it grows until the user first moves it.
    this.userMoved = false;
    this.controls.addEventListener('start', () => { this.userMoved = true; });
    this.exaggeration = 5;
    this.floorFilter = null;  // null: every floor; else the floor index shown from the top
    this.follow = false;
    this.graph = null;
    this.knownLoops = null;  // "a-b" of loop edges in the previous graph (null: no previous)
    this.newLoops = [];      // {a, b, until}
    this.trail = [];
    this.pose = null;
    this.framesDrawn = 0;
    this.drawnGraph = null;  // the graph the last frame drew (for the page's timings)
    this.fitted = false;

    this.group = new THREE.Group();
    this.scene.add(this.group);
    this.nodes = new THREE.Points(new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ size: 4, sizeAttenuation: false, vertexColors: true }));
    this.odometry = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color: 0x8a94a0, transparent: true, opacity: 0.55 }));
    this.loops = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color: 0xff7a33 }));
    this.fresh = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color: 0xffff40 }));
    this.trailLine = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color: 0x40e0ff }));
    this.floors = new THREE.Group();
    this.plan = new PlanLayer();  // the current floor's plan (--plans)
    this.robot = new THREE.Mesh(new THREE.ConeGeometry(0.6, 1.8, 12),
      new THREE.MeshBasicMaterial({ color: 0x40e0ff }));
    this.robot.visible = false;
    // The selected node (a click on it): its id, and a white point drawn over it.
    this.selectedId = null;
    this.marker = new THREE.Points(new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ size: 11, sizeAttenuation: false, color: 0xffffff, depthTest: false }));
    this.marker.renderOrder = 1;
    this.marker.visible = false;
    for (const o of [this.floors, this.plan.group, this.odometry, this.loops, this.fresh, this.nodes, this.trailLine, this.robot, this.marker])
      this.group.add(o);
    for (const o of [this.nodes, this.odometry, this.loops]) o.frustumCulled = false;

    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    const loop = () => { this.draw(); requestAnimationFrame(loop); };
    requestAnimationFrame(loop);
  }

  resize() {
    this.dirty = true;
    const w = Math.max(1, this.container.clientWidth), h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  setExaggeration(v) { this.exaggeration = v; this.rebuild(); this.rebuildTrail(); this.dirty = true; }

  // The map as the viewer sent it ("graph" text, docs/viewer.md).
  setGraph(g) {
    const loops = new Set();
    const e = g.edges;
    const id = g.nodes.id;
    for (let k = 0; k < e.a.length; ++k)
      if (e.kind[k] === 1) loops.add(id[e.a[k]] + '-' + id[e.b[k]]);
    if (this.knownLoops !== null) {
      const until = performance.now() + NEW_CLOSURE_MS;
      for (const key of loops) if (!this.knownLoops.has(key)) {
        const [a, b] = key.split('-').map(Number);
        this.newLoops.push({ a, b, until });
      }
    }
    this.knownLoops = loops;
    this.graph = g;
    this.rebuild();
    if (id.length > 0 && (!this.fitted || (!this.userMoved && !this.fitsInView()))) { this.fit(); this.fitted = true; }
  }

  z(v) { return v * this.exaggeration; }

  // Typed arrays written in place into the geometries' buffers (grown when too small): a
  // 56,000-node map is rebuilt without a JavaScript array of a million numbers.
  rebuild() {
    const g = this.graph;
    if (!g) return;
    const n = g.nodes.id.length, xyz = g.nodes.xyz, fl = g.nodes.floor, se = g.nodes.session;
    const all = this.floorFilter === null;
    const pos = vertexBuffer(this.nodes.geometry, 'position', n);
    const col = vertexBuffer(this.nodes.geometry, 'color', n);
    const ex = this.exaggeration;
    let v = 0;
    for (let i = 0; i < n; ++i) {
      if (!all && fl[i] !== this.floorFilter) continue;
      pos[3 * v] = xyz[3 * i]; pos[3 * v + 1] = xyz[3 * i + 1]; pos[3 * v + 2] = xyz[3 * i + 2] * ex;
      const rgb = SESSION_RGB[((se[i] % SESSION_RGB.length) + SESSION_RGB.length) % SESSION_RGB.length];
      col[3 * v] = rgb[0]; col[3 * v + 1] = rgb[1]; col[3 * v + 2] = rgb[2];
      ++v;
    }
    vertexCount(this.nodes.geometry, v);
    this.index = null;  // node id -> position, made when a new closure needs it
    const e = g.edges, m = e.a.length;
    let loops = 0;
    for (let k = 0; k < m; ++k) if (e.kind[k] === 1) ++loops;
    const odo = vertexBuffer(this.odometry.geometry, 'position', 2 * (m - loops));
    const loop = vertexBuffer(this.loops.geometry, 'position', 2 * loops);
    let no = 0, nl = 0;
    for (let k = 0; k < m; ++k) {
      const a = e.a[k], b = e.b[k];
      if (!all && (fl[a] !== this.floorFilter || fl[b] !== this.floorFilter)) continue;
      const isLoop = e.kind[k] === 1;
      const out = isLoop ? loop : odo;
      const o = isLoop ? 6 * nl++ : 6 * no++;
      out[o] = xyz[3 * a]; out[o + 1] = xyz[3 * a + 1]; out[o + 2] = xyz[3 * a + 2] * ex;
      out[o + 3] = xyz[3 * b]; out[o + 4] = xyz[3 * b + 1]; out[o + 5] = xyz[3 * b + 2] * ex;
    }
    vertexCount(this.odometry.geometry, 2 * no);
    vertexCount(this.loops.geometry, 2 * nl);
    this.rebuildMarker();
    this.rebuildFresh();
    this.rebuildFloors();
    this.updatePlan();
    this.dirty = true;
  }

  // The "plans" text (--plans).
  setPlans(m) { this.plan.setPlans(m); this.updatePlan(); }

  // The current floor: the one shown from the top, else the robot's, else the newest node's.
  currentFloor() {
    if (this.floorFilter !== null) return this.floorFilter;
    if (this.pose && this.pose.floor >= 0) return this.pose.floor;
    const g = this.graph;
    return g && g.nodes.id.length > 0 ? g.nodes.floor[g.nodes.id.length - 1] : null;
  }

  // The current floor's plan under its nodes (the floor grid's height, a little above it).
  updatePlan() {
    const floor = this.currentFloor();
    const f = this.graph ? this.graph.floors.find((x) => x.index === floor) : undefined;
    const shown = this.plan.show(floor, this.z(f ? f.height_m : 0) - 0.2);
    if (shown !== this.planShown) {
      this.planShown = shown;
      this.dirty = true;
      if (this.onPlanShown) this.onPlanShown(floor, shown);
    }
  }

  nodeIndex() {
    if (!this.index) {
      this.index = new Map();
      const id = this.graph.nodes.id;
      for (let i = 0; i < id.length; ++i) this.index.set(id[i], i);
    }
    return this.index;
  }

  // The index in the graph of the node with id `id`, or -1.
  indexOf(id) {
    if (!this.graph || id === null) return -1;
    const i = this.nodeIndex().get(id);
    return i === undefined ? -1 : i;
  }

  // Selects the node with id `id` (null: none); the page shows its details.
  select(id) {
    this.selectedId = id;
    this.rebuildMarker();
  }

  rebuildMarker() {
    const i = this.indexOf(this.selectedId);
    const shown = i >= 0 && (this.floorFilter === null || this.graph.nodes.floor[i] === this.floorFilter);
    this.marker.visible = shown;
    if (shown) {
      const xyz = this.graph.nodes.xyz;
      setPositions(this.marker.geometry, [xyz[3 * i], xyz[3 * i + 1], this.z(xyz[3 * i + 2])]);
    }
    this.dirty = true;
  }

  // Where node `i` of the graph is drawn, in the page's (client) pixels, or null when it is
  // behind the camera. Picking projects the nodes itself: a ray test against points would
  // need bounding volumes the reused buffers do not keep (vertexBuffer below).
  screenOfIndex(i, rect = this.renderer.domElement.getBoundingClientRect(), m = this.viewProjection()) {
    const xyz = this.graph.nodes.xyz, e = m.elements;
    const x = xyz[3 * i], y = xyz[3 * i + 1], z = xyz[3 * i + 2] * this.exaggeration;
    const w = e[3] * x + e[7] * y + e[11] * z + e[15];
    if (!(w > 0)) return null;
    const nx = (e[0] * x + e[4] * y + e[8] * z + e[12]) / w;
    const ny = (e[1] * x + e[5] * y + e[9] * z + e[13]) / w;
    return { x: rect.left + (nx + 1) / 2 * rect.width, y: rect.top + (1 - ny) / 2 * rect.height };
  }

  screenOf(id) {
    const i = this.indexOf(id);
    return i < 0 ? null : this.screenOfIndex(i);
  }

  viewProjection() {
    this.camera.updateMatrixWorld();
    return new THREE.Matrix4().multiplyMatrices(this.camera.projectionMatrix, this.camera.matrixWorldInverse);
  }

  // The id of the shown node drawn nearest the client pixel (x, y), within `radius` pixels;
  // null when there is none.
  pick(x, y, radius = 8) {
    const g = this.graph;
    if (!g) return null;
    const rect = this.renderer.domElement.getBoundingClientRect();
    const m = this.viewProjection();
    let best = null, bestD2 = radius * radius;
    for (let i = 0; i < g.nodes.id.length; ++i) {
      if (this.floorFilter !== null && g.nodes.floor[i] !== this.floorFilter) continue;
      const p = this.screenOfIndex(i, rect, m);
      if (!p) continue;
      const d2 = (p.x - x) ** 2 + (p.y - y) ** 2;
      if (d2 <= bestD2) { bestD2 = d2; best = g.nodes.id[i]; }
    }
    return best;
  }

  rebuildFresh() {
    const g = this.graph;
    const now = performance.now();
    this.newLoops = this.newLoops.filter((l) => l.until > now);
    const pos = [];
    const index = g && this.newLoops.length > 0 ? this.nodeIndex() : null;
    if (g) for (const l of this.newLoops) {
      const a = index.get(l.a), b = index.get(l.b);
      if (a === undefined || b === undefined) continue;
      const xyz = g.nodes.xyz;
      pos.push(xyz[3 * a], xyz[3 * a + 1], this.z(xyz[3 * a + 2]) + 0.05, xyz[3 * b], xyz[3 * b + 1], this.z(xyz[3 * b + 2]) + 0.05);
    }
    setPositions(this.fresh.geometry, pos);
    this.freshCount = this.newLoops.length;
    this.dirty = true;
  }

  // A grid at each floor's height, over the floor's nodes.
  rebuildFloors() {
    for (const child of [...this.floors.children]) { this.floors.remove(child); child.geometry.dispose(); child.material.dispose(); }
    const g = this.graph;
    const box = this.bounds();
    if (!box) return;
    const size = Math.max(box.max.x - box.min.x, box.max.y - box.min.y, 10) * 1.1;
    for (const f of g.floors) {
      if (this.floorFilter !== null && f.index !== this.floorFilter) continue;
      const grid = new THREE.GridHelper(size, 20, 0x34404c, 0x262d35);
      grid.rotation.x = Math.PI / 2;  // GridHelper lies in x-z; the map's floors in x-y
      grid.position.set((box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2, this.z(f.height_m) - 0.3);
      this.floors.add(grid);
    }
  }

  bounds() {
    const g = this.graph;
    if (!g || g.nodes.id.length === 0) return null;
    const box = new THREE.Box3();
    const v = new THREE.Vector3();
    const xyz = g.nodes.xyz;
    for (let i = 0; i < g.nodes.id.length; ++i) {
      if (this.floorFilter !== null && g.nodes.floor[i] !== this.floorFilter) continue;
      box.expandByPoint(v.set(xyz[3 * i], xyz[3 * i + 1], this.z(xyz[3 * i + 2])));
    }
    return box.isEmpty() ? null : box;
  }

  // Whether the shown nodes lie within the extent the view was last fitted to (5 % slack).
  fitsInView() {
    const box = this.bounds();
    if (!box || !this.fittedBox) return false;
    const slack = 0.05 * Math.max(this.fittedBox.getSize(new THREE.Vector3()).length(), 1);
    return this.fittedBox.clone().expandByScalar(slack).containsBox(box);
  }

  fit() {
    const box = this.bounds();
    if (!box) return;
    this.fittedBox = box.clone();
    const centre = box.getCenter(new THREE.Vector3());
    const size = Math.max(box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z, 10);
    this.controls.target.copy(centre);
    if (this.floorFilter === null) {
      this.camera.position.set(centre.x - 0.6 * size, centre.y - 0.9 * size, centre.z + 0.8 * size);
    } else {
      // Top view: straight down (a hair off, so the controls keep their up vector).
      this.camera.position.set(centre.x, centre.y - 0.001 * size, centre.z + 1.3 * size);
    }
    this.controls.update();
  }

  // The log was sought back: what the page remembers of later times goes.
  restart() {
    this.trail = [];
    this.knownLoops = null;
    this.newLoops = [];
    this.trailDirty = true;
  }

  showFloor(index) { this.floorFilter = index; this.rebuild(); this.fit(); }

  setPose(p) {
    this.pose = p;
    this.trail.push([p.xyz[0], p.xyz[1], p.xyz[2], p.session]);
    if (this.trail.length > TRAIL) this.trail.splice(0, this.trail.length - TRAIL);
    this.robot.visible = true;
    this.robot.position.set(p.xyz[0], p.xyz[1], this.z(p.xyz[2]));
    // The cone points along its y axis; the body's forward axis is x.
    const q = new THREE.Quaternion(p.q[1], p.q[2], p.q[3], p.q[0]);
    this.robot.quaternion.copy(q).multiply(new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 0, 1), -Math.PI / 2));
    this.trailDirty = true;
    this.dirty = true;
    if (this.currentFloor() !== (this.plan.shown ? this.plan.shown.floor : null)) this.updatePlan();
  }

  rebuildTrail() {
    const pos = [];
    for (let k = 1; k < this.trail.length; ++k) {
      const a = this.trail[k - 1], b = this.trail[k];
      if (a[3] !== b[3] || Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]) > TRAIL_BREAK_M) continue;
      pos.push(a[0], a[1], this.z(a[2]), b[0], b[1], this.z(b[2]));
    }
    setPositions(this.trailLine.geometry, pos);
    if (this.pose) this.robot.position.set(this.pose.xyz[0], this.pose.xyz[1], this.z(this.pose.xyz[2]));
  }

  draw() {
    if (this.trailDirty) { this.rebuildTrail(); this.trailDirty = false; }
    if (this.newLoops.length > 0 || this.freshCount > 0) this.rebuildFresh();
    if (this.follow && this.pose) {
      const target = new THREE.Vector3(this.pose.xyz[0], this.pose.xyz[1], this.z(this.pose.xyz[2]));
      const shift = target.clone().sub(this.controls.target);
      this.controls.target.add(shift);
      this.camera.position.add(shift);
    }
    this.controls.update();  // damping: emits 'change' while the view still moves
    if (!this.dirty) return;
    const now = performance.now();
    if (now - this.lastFrame < this.minFrameMs) return;
    this.lastFrame = now;
    this.dirty = false;
    const renderStart = performance.timeOrigin + now;
    this.renderer.render(this.scene, this.camera);
    ++this.framesDrawn;
    if (this.onDrawn) this.onDrawn();
    if (this.graph !== null && this.graph !== this.drawnGraph) {
      this.drawnGraph = this.graph;
      if (this.onGraphDrawn) this.onGraphDrawn(this.graph, renderStart, performance.timeOrigin + performance.now());
    }
  }
}

function rendererName(renderer) {
  const gl = renderer.getContext();
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  return String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
}

// The array of `geometry`'s attribute `name` (3 floats a vertex), with room for `vertices`:
// the buffer is reused while it is big enough (sent again to the GPU in place), else replaced
// by one half as big again. Objects drawn from these buffers are not frustum-culled (their
// bounding spheres would count stale vertices past the draw range).
function vertexBuffer(geometry, name, vertices) {
  let attr = geometry.getAttribute(name);
  if (!attr || attr.array.length < 3 * vertices) {
    attr = new THREE.BufferAttribute(new Float32Array(3 * Math.max(16, Math.ceil(vertices * 1.5))), 3);
    attr.setUsage(THREE.DynamicDrawUsage);
    geometry.setAttribute(name, attr);
  }
  attr.needsUpdate = true;
  return attr.array;
}

function vertexCount(geometry, vertices) {
  geometry.setDrawRange(0, vertices);
  // Only the used part goes to the GPU.
  for (const name of ['position', 'color']) {
    const attr = geometry.getAttribute(name);
    if (!attr) continue;
    attr.clearUpdateRanges();
    attr.addUpdateRange(0, 3 * vertices);
  }
}

function setPositions(geometry, positions, colours) {
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  if (colours) geometry.setAttribute('color', new THREE.Float32BufferAttribute(colours, 3));
  geometry.computeBoundingSphere();
}
