// The 3-D map (three.js): floors stacked with the vertical axis exaggerated as in the paper's
// Fig. 1, nodes coloured by session, odometry and loop-closure edges told apart, newly
// accepted closures highlighted, the robot's pose and its recent trail. Orbit, pan and zoom
// with the mouse (OrbitControls); a top view per floor.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const SESSION_COLOURS = [0x5fb3ff, 0x7ddc6f, 0xe36bd8, 0xf2d64b, 0x59e0c8, 0xb48cff, 0xff5f7a,
                         0xc0c0c0, 0x3fd17f, 0xffa0e0];
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
    this.robot = new THREE.Mesh(new THREE.ConeGeometry(0.6, 1.8, 12),
      new THREE.MeshBasicMaterial({ color: 0x40e0ff }));
    this.robot.visible = false;
    for (const o of [this.floors, this.odometry, this.loops, this.fresh, this.nodes, this.trailLine, this.robot])
      this.group.add(o);

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
    if (!this.fitted && id.length > 0) { this.fit(); this.fitted = true; }
  }

  z(v) { return v * this.exaggeration; }

  rebuild() {
    const g = this.graph;
    if (!g) return;
    const n = g.nodes.id.length, xyz = g.nodes.xyz, fl = g.nodes.floor, se = g.nodes.session;
    const keep = (i) => this.floorFilter === null || fl[i] === this.floorFilter;
    const pos = [], col = [], c = new THREE.Color();
    this.index = new Map();
    for (let i = 0; i < n; ++i) {
      this.index.set(g.nodes.id[i], i);
      if (!keep(i)) continue;
      pos.push(xyz[3 * i], xyz[3 * i + 1], this.z(xyz[3 * i + 2]));
      c.setHex(SESSION_COLOURS[((se[i] % SESSION_COLOURS.length) + SESSION_COLOURS.length) % SESSION_COLOURS.length]);
      col.push(c.r, c.g, c.b);
    }
    setPositions(this.nodes.geometry, pos, col);
    const odo = [], loop = [];
    const e = g.edges;
    for (let k = 0; k < e.a.length; ++k) {
      const a = e.a[k], b = e.b[k];
      if (!keep(a) || !keep(b)) continue;
      const out = e.kind[k] === 1 ? loop : odo;
      out.push(xyz[3 * a], xyz[3 * a + 1], this.z(xyz[3 * a + 2]), xyz[3 * b], xyz[3 * b + 1], this.z(xyz[3 * b + 2]));
    }
    setPositions(this.odometry.geometry, odo);
    setPositions(this.loops.geometry, loop);
    this.rebuildFresh();
    this.rebuildFloors();
    this.dirty = true;
  }

  rebuildFresh() {
    const g = this.graph;
    const now = performance.now();
    this.newLoops = this.newLoops.filter((l) => l.until > now);
    const pos = [];
    if (g) for (const l of this.newLoops) {
      const a = this.index.get(l.a), b = this.index.get(l.b);
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

  fit() {
    const box = this.bounds();
    if (!box) return;
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

function setPositions(geometry, positions, colours) {
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  if (colours) geometry.setAttribute('color', new THREE.Float32BufferAttribute(colours, 3));
  geometry.computeBoundingSphere();
}
