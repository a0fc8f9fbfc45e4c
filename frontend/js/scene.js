// The top-down scene on a <canvas>: world<->screen transform, density of points, camera glyphs,
// frustum triangles, match lines, comparison arrows, proposed poses (ghost cameras), split-off
// models' rings, the path being drawn and a scale bar. It draws what it is told: the page forwards
// the store's "lines", "arrows", "ghosts", "sketch", "display" and "view" events to it.
import { DensityLayer } from "./density.js";
import { median, viewExtent } from "./geometry.js";
import { drawArrows, drawFrusta, drawGlyphs, drawLabels, drawScaleBar, drawSegments } from "./glyphs.js";
import { drawGroupOutlines, drawProposals, drawSketch, groupsOf } from "./overlays.js";
const COLOURS = ["points", "camera", "moved", "unregistered", "flagged", "selected", "hovered",
  "match", "cut", "estimate", "arrow", "ghost", "frustum", "order", "group", "proposal", "sketch"];

export class SceneView {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.density = new DensityLayer();
    this.view = { cx: 0, cy: 0, scale: 1 }; // scale: device pixels per world unit
    this.cameras = [];
    this.points = new Float32Array(0);
    this.poseOf = modelPose;
    this.base = new Map(); // image id -> model pose, for ghosts of moved cameras
    this.byId = new Map();
    this.selected = new Set();
    this.moved = new Set();
    this.flagged = new Set();
    this.hovered = null;
    this.showFrusta = false;
    this.showOrder = true; // the capture-order line and labels
    this.metresPerUnit = null; // set from a known distance: the scale bar then speaks metres
    this.lines = []; // [{a, b, kind: "match"|"cut"|"estimate", weight}]
    this.arrows = []; // [{from: [x, y], to: [x, y]}]
    this.ghosts = []; // [{id, x, y, yaw_deg, hot}]: proposed poses
    this.sketch = null; // the path being drawn
    this.colours = readColours(canvas);
    this.frame = 0;
    this.generation = 0; // bump to force the static layer to redraw (e.g. new colours)
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  // New cameras and points; the poses are the model's until an editor sets poseOf.
  setScene(cameras, points) {
    this.poseOf = modelPose;
    this.overlay = null;
    this.selected = new Set();
    this.moved = new Set();
    this.flagged = new Set();
    this.hovered = null;
    this.cameras = cameras;
    this.points = points;
    this.base = new Map(cameras.filter((c) => c.x !== null).map((c) => [c.id, c]));
    this.byId = new Map(cameras.map((c) => [c.id, c]));
  }

  // Match lines; the estimate's and the server's cut lines are the red ones.
  setLines(lines) {
    this.lines = lines;
    this.canvas.dataset.lines = String(lines.length);
    this.canvas.dataset.redLines = String(lines.filter((l) => l.kind !== "match").length);
    this.requestDraw();
  }

  // Proposed poses (ghost cameras), each joined by a dashed line to where its camera is now.
  setGhosts(ghosts) {
    this.ghosts = ghosts;
    this.canvas.dataset.ghosts = String(ghosts.length);
    this.requestDraw();
  }

  setSketch(sketch) {
    this.sketch = sketch;
    this.canvas.dataset.sketch = sketch?.kind ?? "";
    this.requestDraw();
  }

  setArrows(arrows) {
    this.arrows = arrows;
    this.canvas.dataset.arrows = String(arrows.length);
    this.requestDraw();
  }

  // A command from the toolbar or the keys: fit, zoom about the centre, pan by a share of the view;
  // show: a world point, centred when it is off screen (e.g. a suspect picked in its panel).
  command({ fit, zoom, pan, show }) {
    if (show) this.bringIntoView(show);
    if (fit) this.fit();
    if (zoom) {
      const rect = this.canvas.getBoundingClientRect();
      this.zoomAt(rect.left + rect.width / 2, rect.top + rect.height / 2, zoom);
    }
    if (pan) {
      const span = this.canvas.width / this.view.scale;
      this.panBy(pan[0] * span, pan[1] * span);
    }
  }

  bringIntoView([x, y]) {
    const [sx, sy] = this.transform()(x, y);
    const margin = 0.05 * Math.min(this.canvas.width, this.canvas.height);
    const { width, height } = this.canvas;
    if (sx > margin && sy > margin && sx < width - margin && sy < height - margin) return;
    Object.assign(this.view, { cx: x, cy: y });
    this.requestDraw();
  }

  resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(this.canvas.clientWidth * dpr));
    const h = Math.max(1, Math.round(this.canvas.clientHeight * dpr));
    if (w !== this.canvas.width || h !== this.canvas.height) {
      this.canvas.width = w;
      this.canvas.height = h;
      this.requestDraw();
    }
  }

  // Frame the placed cameras and the points near them (viewExtent: far stray points stay out).
  fit() {
    const posed = this.posedCameras();
    const ranges = posed.map(([, p]) => p.range).filter((r) => r > 0);
    const extent = viewExtent(posed.map(([, p]) => [p.x, p.y]), this.points, median(ranges) ?? 0);
    if (!extent) return;
    const [x0, y0, x1, y1] = extent;
    const { width, height } = this.canvas;
    this.view.cx = (x0 + x1) / 2;
    this.view.cy = (y0 + y1) / 2;
    this.view.scale = 0.9 * Math.min(width / Math.max(x1 - x0, 1e-9), height / Math.max(y1 - y0, 1e-9));
    this.requestDraw();
  }

  // Client (CSS pixel) coordinates of an event to world coordinates.
  toWorld(clientX, clientY) {
    const rect = this.canvas.getBoundingClientRect();
    const dpr = this.canvas.width / rect.width;
    const { cx, cy, scale } = this.view;
    return [cx + ((clientX - rect.left) * dpr - this.canvas.width / 2) / scale,
      cy - ((clientY - rect.top) * dpr - this.canvas.height / 2) / scale];
  }

  // World units per CSS pixel at the current zoom.
  worldPerPixel() {
    return this.canvas.width / this.canvas.getBoundingClientRect().width / this.view.scale;
  }

  panBy(dxWorld, dyWorld) {
    this.view.cx -= dxWorld;
    this.view.cy -= dyWorld;
    this.requestDraw();
  }

  zoomAt(clientX, clientY, factor) {
    const [wx, wy] = this.toWorld(clientX, clientY);
    this.view.scale *= factor;
    const [ax, ay] = this.toWorld(clientX, clientY);
    this.panBy(ax - wx, ay - wy);
  }

  // The camera whose glyph is nearest a client point, within `radius` CSS pixels.
  hitTest(clientX, clientY, radius = 9) {
    const [wx, wy] = this.toWorld(clientX, clientY);
    const dpr = this.canvas.width / this.canvas.getBoundingClientRect().width;
    let best = null;
    let bestD = (radius * dpr) / this.view.scale;
    for (const cam of this.cameras) {
      const p = this.poseOf(cam);
      if (!p) continue;
      const d = Math.hypot(p.x - wx, p.y - wy);
      if (d < bestD) { best = cam.id; bestD = d; }
    }
    return best;
  }

  requestDraw() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => { this.pending = 0; this.draw(); });
  }

  // World to device pixels, as a closure for the glyph functions.
  transform() {
    const { cx, cy, scale } = this.view;
    const ox = this.canvas.width / 2 - cx * scale;
    const oy = this.canvas.height / 2 + cy * scale;
    return (x, y) => [x * scale + ox, oy - y * scale];
  }

  draw() {
    const { ctx, canvas, colours } = this;
    const px = window.devicePixelRatio || 1;
    const t = this.transform();
    const posed = this.posedCameras();
    const dynamic = posed.filter(([cam]) => cam.id === this.hovered || this.selected.has(cam.id));
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.drawImage(this.staticLayer(posed, t, px), 0, 0);
    const ordered = this.showOrder ? [...posed].sort((a, b) => a[0].seq - b[0].seq) : [];
    this.drawOrderLine(t, ordered, px);
    if (this.showFrusta) {
      drawFrusta(ctx, t, dynamic, { fill: colours.selectedFaint, stroke: colours.selected, px });
    }
    this.drawGhosts(t, px);
    this.drawTriage(t, posed, px);
    this.drawLines(t, px);
    drawArrows(ctx, t, this.arrows, { colour: colours.arrow, px });
    this.drawCameras(ctx, t, dynamic, px);
    this.drawHoverRing(t, posed, px);
    this.drawOrderLabels(t, ordered, px);
    if (posed.length || this.points.length) this.drawScale(px);
    if (this.sketch) drawSketch(ctx, t, this.sketch, { colour: colours.sketch, px });
    this.overlay?.(ctx, t, px); // e.g. comment pins, drawn by their panel
    this.frame += 1;
    Object.assign(canvas.dataset, { frame: String(this.frame), hovered: String(this.hovered ?? ""),
      view: `${this.view.cx},${this.view.cy},${this.view.scale}`, cameras: String(this.cameras.length),
      points: String(this.points.length / 2) });
  }

  drawScale(px) {
    const { ctx, canvas, colours } = this;
    const [length, label] = drawScaleBar(ctx, { width: canvas.width, height: canvas.height, scale: this.view.scale,
      metresPerUnit: this.metresPerUnit,
      px, ink: colours.ink, background: colours.scaleBg });
    canvas.dataset.scaleBar = String(length);
    canvas.dataset.scaleLabel = label;
  }

  // Points and every camera that is neither selected nor hovered, redrawn only when they change
  // (moving a selection redraws just the selection on top).
  staticLayer(posed, t, px) {
    const items = posed.filter(([cam]) => cam.id !== this.hovered && !this.selected.has(cam.id));
    const key = this.staticKey(items);
    if (sameKey(key, this.lastKey)) return this.layer;
    this.lastKey = key;
    this.layer ??= document.createElement("canvas");
    const { layer, canvas, colours } = this;
    layer.width = canvas.width;
    layer.height = canvas.height;
    const ctx = layer.getContext("2d");
    const density = this.density.render(this.points, this.view, canvas.width, canvas.height, colours.pointsRgb);
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(density, 0, 0, canvas.width, canvas.height);
    if (this.showFrusta) drawFrusta(ctx, t, items, { fill: colours.frustumFaint, stroke: colours.frustum, px });
    this.drawCameras(ctx, t, items, px);
    return layer;
  }

  staticKey(items) {
    const { cx, cy, scale } = this.view;
    const key = new Float64Array(8 + 7 * items.length);
    key.set([cx, cy, scale, this.canvas.width, this.canvas.height, this.showFrusta ? 1 : 0,
      this.points.length, this.generation]);
    let k = 8;
    for (const [cam, p] of items) {
      key[k++] = cam.id;
      key[k++] = CATEGORIES.indexOf(this.categoryOf(cam));
      key[k++] = p.x;
      key[k++] = p.y;
      key[k++] = p.yaw_deg;
      key[k++] = p.fov_deg ?? -1;
      key[k++] = p.range ?? -1;
    }
    return key;
  }

  drawHoverRing(t, posed, px) {
    const hovered = posed.find(([cam]) => cam.id === this.hovered);
    if (!hovered) return;
    const [sx, sy] = t(hovered[1].x, hovered[1].y);
    this.ctx.beginPath();
    this.ctx.arc(sx, sy, 8 * px, 0, 2 * Math.PI);
    this.ctx.lineWidth = 2 * px;
    this.ctx.strokeStyle = this.colours.hovered;
    this.ctx.stroke();
  }

  // The capture order: a thin line joining consecutive placed cameras (by seq; drawn each frame,
  // as it follows a dragged selection) ...
  drawOrderLine(t, ordered, px) {
    const segments = [];
    for (let i = 1; i < ordered.length; i++) {
      const [a, b] = [ordered[i - 1][1], ordered[i][1]];
      segments.push([a.x, a.y, b.x, b.y]);
    }
    drawSegments(this.ctx, t, segments, { colour: this.colours.order, width: px });
    this.canvas.dataset.orderSegments = String(segments.length);
  }

  // ... and each camera's number (#seq + 1, as in the strip's titles), thinned where they overlap.
  drawOrderLabels(t, ordered, px) {
    const labels = drawLabels(this.ctx, t, ordered.map(([cam, p]) => [`${cam.seq + 1}`, p]),
      { colour: this.colours.ink, halo: this.colours.scaleBg, px });
    this.canvas.dataset.labels = JSON.stringify(labels);
  }

  posedCameras() {
    const out = [];
    for (const cam of this.cameras) {
      const pose = this.poseOf(cam);
      if (pose) out.push([cam, pose]);
    }
    return out;
  }

  drawGhosts(t, px) {
    const segments = [];
    for (const id of this.moved) {
      const from = this.base.get(id);
      const to = from && this.poseOf(from);
      if (to) segments.push([from.x, from.y, to.x, to.y]);
    }
    drawSegments(this.ctx, t, segments, { colour: this.colours.ghost, width: px, dash: [3 * px, 3 * px] });
  }

  // Proposed poses and the rings of split-off models (at their group poses or where moved).
  drawTriage(t, posed, px) {
    const nowOf = (id) => { const cam = this.byId.get(id); return cam ? this.poseOf(cam) : null; };
    drawProposals(this.ctx, t, this.ghosts, nowOf, { colour: this.colours.proposal, px });
    const groups = groupsOf(posed);
    drawGroupOutlines(this.ctx, t, groups, { colour: this.colours.group, px });
    this.canvas.dataset.groups = String(groups.size);
  }

  drawLines(t, px) {
    if (!this.lines.length) return;
    const byId = new Map();
    for (const cam of this.cameras) {
      const pose = this.poseOf(cam);
      if (pose) byId.set(cam.id, pose);
    }
    const groups = new Map(); // "kind width" -> segments
    for (const line of this.lines) {
      const a = byId.get(line.a);
      const b = byId.get(line.b);
      if (!a || !b) continue;
      const width = Math.min(4, Math.max(1, Math.round(line.weight ?? 1)));
      const key = `${LINE_ORDER.indexOf(line.kind)} ${width}`;
      if (!groups.has(key)) groups.set(key, []);
      groups.get(key).push([a.x, a.y, b.x, b.y]);
    }
    for (const key of [...groups.keys()].sort()) {
      const [order, width] = key.split(" ").map(Number);
      const kind = LINE_ORDER[order];
      drawSegments(this.ctx, t, groups.get(key), { colour: this.colours[kind], width: width * px,
        dash: kind === "estimate" ? [4 * px, 3 * px] : [] });
    }
  }

  // Selected wins over hovered (a ring shows the hover), so hovering never hides a selection.
  categoryOf(cam) {
    if (this.selected.has(cam.id)) return "selected";
    if (cam.id === this.hovered) return "hovered";
    if (this.flagged.has(cam.id)) return "flagged";
    if (cam.group) return "group";
    if (!cam.registered) return "unregistered";
    return this.moved.has(cam.id) ? "moved" : "camera";
  }

  drawCameras(ctx, t, posed, px) {
    const groups = new Map(CATEGORIES.map((name) => [name, []]));
    for (const item of posed) groups.get(this.categoryOf(item[0])).push(item);
    for (const [name, items] of groups) {
      if (!items.length) continue;
      const big = name === "selected" || name === "hovered";
      drawGlyphs(ctx, t, items, { radius: (big ? 4.5 : 3.2) * px, length: (big ? 15 : 10) * px,
        colour: this.colours[name], px });
    }
  }
}

// Before an editor is attached: the model's pose, else a split-off model's group pose.
const modelPose = (cam) => (cam.x !== null ? cam : cam.group && { ...cam, ...cam.group });
const CATEGORIES = ["camera", "unregistered", "group", "moved", "flagged", "selected", "hovered"];
const LINE_ORDER = ["match", "estimate", "cut"];

function sameKey(a, b) {
  if (!b || a.length !== b.length) return false;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
  return true;
}

function readColours(element) {
  const style = getComputedStyle(element);
  const colours = {};
  for (const name of COLOURS) colours[name] = style.getPropertyValue(`--c-${name}`).trim() || "#888";
  colours.ink = style.getPropertyValue("--ink").trim() || "#111";
  colours.scaleBg = "rgba(255, 255, 255, 0.8)";
  colours.selectedFaint = "rgba(221, 107, 32, 0.12)";
  colours.frustumFaint = "rgba(43, 108, 176, 0.05)";
  colours.pointsRgb = hexRgb(colours.points);
  return colours;
}

function hexRgb(hex) {
  const m = /^#([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i.exec(hex);
  return m ? m.slice(1).map((h) => parseInt(h, 16)) : [60, 60, 60];
}
