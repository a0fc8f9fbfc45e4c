// A 3D look at the version on screen, beside the top-down view: the model's points in their
// colours (the version's PLY export), a frustum per registered camera (from the scene's centre and
// world-to-camera quaternion), the draft's moved cameras highlighted; orbit, pan and zoom.
// three.js is vendored under frontend/vendor/ and loaded through the page's import map.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { session } from "./api.js";

const COLOURS = { camera: 0x2b6cb0, moved: 0xdd6b20 };

export class View3D {
  constructor(root, { store, draft, projectId }, signal) {
    Object.assign(this, { root, store, draft, projectId });
    this.wrap = root.querySelector(".scene-wrap");
    this.canvas = root.querySelector("#scene3d");
    this.button = root.querySelector("#show-3d");
    this.button.addEventListener("click", () => this.toggle(), { signal });
    store.on("draft", () => this.recolour());
    signal.addEventListener("abort", () => this.close());
  }

  async toggle(on = this.canvas.hidden) {
    this.canvas.hidden = !on;
    this.wrap.classList.toggle("split", on);
    this.button.setAttribute("aria-pressed", String(on));
    if (!on) return this.stop();
    try {
      if (this.loadedFor !== this.store.version?.id) await this.load();
      this.resize();
      this.render();
    } catch (error) {
      this.canvas.dataset.error = error.message;
    }
  }

  async load() {
    const version = this.store.version;
    if (!version) return;
    const base = `/api/v1/projects/${this.projectId}/versions/${version.id}`;
    const headers = { Authorization: `Bearer ${session.token}` };
    const [scene, ply] = await Promise.all([
      fetch(`${base}/scene`, { headers }).then((r) => r.json()),
      fetch(`${base}/export?format=ply`, { headers }).then((r) => r.arrayBuffer())]);
    this.build(scene, readPly(ply));
    this.loadedFor = version.id;
  }

  build(scene, cloud) {
    this.renderer ??= new THREE.WebGLRenderer({ canvas: this.canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setClearColor(0xfbfcfd);
    this.scene = new THREE.Scene();
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.BufferAttribute(cloud.positions, 3));
    geometry.setAttribute("color", new THREE.BufferAttribute(cloud.colours, 3));
    this.scene.add(new THREE.Points(geometry, new THREE.PointsMaterial({ size: 3, sizeAttenuation: false,
      vertexColors: true })));
    const cameras = scene.cameras.filter((c) => c.registered && c.center && c.qvec);
    const { center, radius } = extent(cameras, cloud);
    this.frusta = cameras.map((c) => frustum(c, radius * 0.06));
    for (const lines of this.frusta) this.scene.add(lines);
    this.camera = new THREE.PerspectiveCamera(50, 1, radius / 100, radius * 20);
    this.camera.up.fromArray(scene.frame.up);
    const up = new THREE.Vector3().fromArray(scene.frame.up);
    const across = new THREE.Vector3().fromArray(scene.frame.y_axis).negate();
    this.camera.position.copy(center).addScaledVector(up, radius * 1.2).addScaledVector(across, radius * 1.4);
    this.controls?.dispose();
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.target.copy(center);
    this.controls.addEventListener("change", () => this.render());
    Object.assign(this.canvas.dataset, { points: String(cloud.count), frusta: String(this.frusta.length) });
    this.recolour();
  }

  // Frusta of the cameras the draft moves take the "moved" colour.
  recolour() {
    if (!this.frusta) return;
    const moved = new Set(this.draft.cameras.keys());
    for (const lines of this.frusta) {
      lines.material.color.setHex(moved.has(lines.userData.id) ? COLOURS.moved : COLOURS.camera);
    }
    this.canvas.dataset.moved = [...moved].join(",");
    this.render();
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas;
    if (!this.renderer || !w || !h) return;
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  render() {
    if (!this.renderer || this.canvas.hidden) return;
    this.renderer.render(this.scene, this.camera);
    this.canvas.dataset.frames = String(Number(this.canvas.dataset.frames ?? 0) + 1);
  }

  stop() { this.canvas.dataset.frames = "0"; }

  close() {
    this.controls?.dispose();
    this.renderer?.dispose();
    this.renderer = null;
    this.wrap.classList.remove("split");
    this.canvas.hidden = true;
    this.button.setAttribute("aria-pressed", "false");
  }
}

// What to frame: the cameras' centroid and the distance holding 90% of the points around it
// (a few far points would otherwise shrink the scene to a dot).
function extent(cameras, cloud) {
  const center = new THREE.Vector3();
  for (const c of cameras) center.add(new THREE.Vector3().fromArray(c.center));
  center.divideScalar(Math.max(cameras.length, 1));
  const distances = [];
  for (let i = 0; i < cloud.count; i++) {
    const p = cloud.positions;
    distances.push(Math.hypot(p[3 * i] - center.x, p[3 * i + 1] - center.y, p[3 * i + 2] - center.z));
  }
  distances.sort((a, b) => a - b);
  return { center, radius: distances[Math.floor(0.9 * (distances.length - 1))] || 1 };
}

// A camera's viewing pyramid: apex at its centre, base `depth` ahead, as line segments.
function frustum(cam, depth) {
  const [w, x, y, z] = cam.qvec; // world-to-camera rotation; its rows are the camera's axes in the world
  const rows = new THREE.Matrix4().makeRotationFromQuaternion(new THREE.Quaternion(x, y, z, w)).transpose();
  const [right, down, ahead] = [0, 1, 2].map((i) => new THREE.Vector3().setFromMatrixColumn(rows, i));
  const half = Math.tan(((cam.fov_deg ?? 60) * Math.PI) / 360) * depth;
  const apex = new THREE.Vector3().fromArray(cam.center);
  const corners = [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(([sx, sy]) => apex.clone()
    .addScaledVector(ahead, depth).addScaledVector(right, sx * half).addScaledVector(down, sy * half * 0.75));
  const points = [];
  corners.forEach((corner, i) => points.push(apex, corner, corner, corners[(i + 1) % 4]));
  const lines = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(points),
    new THREE.LineBasicMaterial({ color: COLOURS.camera }));
  lines.userData.id = cam.image_id;
  return lines;
}

// A binary little-endian PLY's vertices: positions and colours (0..1), whatever else they carry.
export function readPly(buffer) {
  const bytes = new Uint8Array(buffer);
  const end = findHeaderEnd(bytes);
  const header = new TextDecoder().decode(bytes.subarray(0, end)).split("\n");
  const count = Number(header.find((l) => l.startsWith("element vertex")).split(" ")[2]);
  const SIZES = { float: 4, float32: 4, double: 8, uchar: 1, uint8: 1, int: 4, uint: 4, short: 2, ushort: 2 };
  const props = [];
  let stride = 0;
  for (const line of header.filter((l) => l.startsWith("property "))) {
    const [, type, name] = line.trim().split(" ");
    props.push({ name, type, offset: stride });
    stride += SIZES[type];
  }
  const view = new DataView(buffer, end);
  const at = Object.fromEntries(props.map((p) => [p.name, p]));
  const positions = new Float32Array(count * 3);
  const colours = new Float32Array(count * 3);
  for (let i = 0; i < count; i++) {
    const row = i * stride;
    ["x", "y", "z"].forEach((k, j) => { positions[3 * i + j] = view.getFloat32(row + at[k].offset, true); });
    ["red", "green", "blue"].forEach((k, j) => { colours[3 * i + j] = at[k] ? view.getUint8(row + at[k].offset) / 255 : 0.3; });
  }
  return { count, positions, colours };
}

function findHeaderEnd(bytes) {
  const marker = new TextEncoder().encode("end_header\n");
  for (let i = 0; i < Math.min(bytes.length, 4096); i++) {
    if (marker.every((b, j) => bytes[i + j] === b)) return i + marker.length;
  }
  throw new Error("not a PLY file");
}
