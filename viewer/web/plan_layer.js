// One floor's plan (evermap-viewer --plans: evermap-map-export's occupancy grids, the "plans"
// text of docs/viewer.md) drawn under the graph at the floor's height: free cells dark,
// occupied cells light, unknown cells not drawn. Only the current floor's plan is shown.
import * as THREE from 'three';

const FREE = [38, 48, 62, 255];
const OCCUPIED = [226, 232, 240, 255];

// The cells of a plan, one byte each (0 unknown, 1 free, 2 occupied), from its runs
// ("u12f30o2...").
export function decodeCells(plan) {
  const cells = new Uint8Array(plan.width * plan.height);
  const runs = plan.cells;
  let at = 0;
  for (let k = 0; k < runs.length;) {
    const code = runs[k] === 'o' ? 2 : (runs[k] === 'f' ? 1 : 0);
    let n = 0;
    ++k;
    while (k < runs.length && runs.charCodeAt(k) >= 48 && runs.charCodeAt(k) <= 57) n = 10 * n + runs.charCodeAt(k++) - 48;
    cells.fill(code, at, Math.min(cells.length, at + n));
    at += n;
  }
  if (at !== cells.length) throw new Error(`floor ${plan.floor}'s plan holds ${at} cells, not ${cells.length}`);
  return cells;
}

export class PlanLayer {
  constructor() {
    this.group = new THREE.Group();
    this.plans = new Map();  // floor -> the plan as sent
    this.mesh = null;
    this.shown = null;       // {floor, z, version} of the mesh
    this.version = 0;
  }

  // A new "plans" text: the meshes are made again when next shown.
  setPlans(m) {
    this.plans = new Map(m.floors.map((p) => [p.floor, p]));
    ++this.version;
    this.shown = null;
  }

  // Shows floor `floor`'s plan at height z (drawn units), or nothing; what is shown, or null.
  show(floor, z) {
    const plan = floor === null ? undefined : this.plans.get(floor);
    if (this.shown && this.shown.floor === floor && this.shown.z === z && this.shown.version === this.version)
      return this.shown.plan;
    this.clear();
    this.shown = { floor, z, version: this.version, plan: plan || null };
    if (!plan) return null;
    const cells = decodeCells(plan);
    const rgba = new Uint8Array(4 * cells.length);
    for (let i = 0; i < cells.length; ++i) {
      if (cells[i] === 0) continue;
      rgba.set(cells[i] === 2 ? OCCUPIED : FREE, 4 * i);
    }
    // Row 0 of the texture is the plan's bottom row (map_server's origin corner).
    const texture = new THREE.DataTexture(rgba, plan.width, plan.height, THREE.RGBAFormat);
    texture.colorSpace = THREE.SRGBColorSpace;  // the colours above as they are
    texture.magFilter = THREE.NearestFilter;
    texture.minFilter = THREE.NearestFilter;
    texture.needsUpdate = true;
    const w = plan.width * plan.resolution_m, h = plan.height * plan.resolution_m;
    const mesh = new THREE.Mesh(new THREE.PlaneGeometry(w, h),
      new THREE.MeshBasicMaterial({ map: texture, transparent: true, depthWrite: false, side: THREE.DoubleSide }));
    const [x0, y0, yaw] = plan.origin;
    const c = Math.cos(yaw), s = Math.sin(yaw);
    mesh.position.set(x0 + c * w / 2 - s * h / 2, y0 + s * w / 2 + c * h / 2, z);
    mesh.rotation.z = yaw;
    mesh.renderOrder = -1;  // under the graph
    this.mesh = mesh;
    this.group.add(mesh);
    return plan;
  }

  clear() {
    if (!this.mesh) return;
    this.group.remove(this.mesh);
    this.mesh.geometry.dispose();
    this.mesh.material.map.dispose();
    this.mesh.material.dispose();
    this.mesh = null;
  }
}
