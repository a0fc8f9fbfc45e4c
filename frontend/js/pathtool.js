// The path tool: draw a polyline (clicks; double-click or Enter finishes, Backspace drops the
// last corner) or a circle for an orbit (press at the centre, release where the first camera goes)
// on the scene, and lay the selected capture-order stretch along it (paths.js) as ordinary moves
// of the draft: one undo step. While drawing, the tool takes the scene's pointer (store.tool) and
// Enter/Escape; `l` and `c` start it. The scene draws the sketch from the store ("sketch").
import { alongCircle, alongPolyline, meanStep, pathLength, spacing, turnDirection } from "./paths.js";

const FORM_FIELDS = "input, textarea, select, [contenteditable]";
const MIN_PIXELS = 4; // corners closer than this on screen are one (a double-click's two clicks)

export class PathTool {
  constructor(root, { store, editor, notify }, signal) {
    Object.assign(this, { root, store, editor, notify });
    this.buttons = { polyline: root.querySelector("#draw-path"), circle: root.querySelector("#draw-orbit") };
    this.yaw = root.querySelector("#path-yaw");
    this.status = root.querySelector("#path-status");
    for (const [kind, button] of Object.entries(this.buttons)) {
      button.addEventListener("click", () => this.toggle(kind), { signal });
    }
    // capture: Escape and Enter end the drawing before the editor's keys see them
    document.addEventListener("keydown", (e) => this.onKey(e), { signal, capture: true });
    store.on("selection", () => this.refresh());
    this.refresh();
  }

  // The selected cameras in capture order.
  stretch() {
    const cams = [...this.store.selection].map((id) => this.store.byId.get(id)).filter(Boolean);
    return cams.sort((a, b) => a.seq - b.seq);
  }

  toggle(kind) {
    if (this.store.tool?.kind === kind) this.stop("Drawing cancelled.");
    else this.start(kind);
  }

  start(kind) {
    if (!this.editor.canEdit()) return;
    if (this.stretch().length < 2) {
      this.notify("Select the capture-order stretch to lay along a path first (two cameras or more).");
      return;
    }
    this.sketch = kind === "circle" ? { kind, centre: null, radius: 0, start: null } : { kind, points: [], cursor: null };
    this.store.tool = kind === "circle" ? this.circleTool() : this.polylineTool();
    this.show(kind === "circle" ? "Press at the orbit's centre and drag out to where the first camera goes."
      : "Click the path's corners from where the first camera goes; double-click or Enter finishes, Escape cancels.");
  }

  polylineTool() {
    const sketch = this.sketch;
    return { kind: "polyline",
      down: ([x, y], e, perPixel) => {
        const last = sketch.points.at(-1);
        if (!last || Math.hypot(x - last[0], y - last[1]) > MIN_PIXELS * perPixel) sketch.points.push([x, y]);
        this.draw();
      },
      move: (at) => { sketch.cursor = at; this.draw(); },
      dblclick: () => this.finish(),
    };
  }

  circleTool() {
    const sketch = this.sketch;
    return { kind: "circle",
      down: (at) => { Object.assign(sketch, { centre: at, radius: 0, start: null }); this.draw(); },
      move: (at) => {
        if (!sketch.centre) return;
        Object.assign(sketch, { start: at, radius: Math.hypot(at[0] - sketch.centre[0], at[1] - sketch.centre[1]) });
        this.draw();
      },
      up: (_at, _e, perPixel) => {
        if (sketch.centre && sketch.radius > MIN_PIXELS * perPixel) this.finish();
        else sketch.centre = null; // a click without a drag: no circle yet
      },
    };
  }

  onKey(e) {
    if (e.target.closest?.(FORM_FIELDS) || e.ctrlKey || e.metaKey || e.altKey) return;
    const tool = this.store.tool;
    let handled = true;
    if (tool && e.key === "Escape") this.stop("Drawing cancelled.");
    else if (tool?.kind === "polyline" && e.key === "Enter") this.finish();
    else if (tool?.kind === "polyline" && e.key === "Backspace") { this.sketch.points.pop(); this.draw(); }
    else if (!tool && e.key.toLowerCase() === "l") this.start("polyline");
    else if (!tool && e.key.toLowerCase() === "c") this.start("circle");
    else handled = false;
    if (handled) {
      e.preventDefault();
      e.stopImmediatePropagation();
    }
  }

  // Lay the stretch along the sketch: one undo step of ordinary moves.
  finish() {
    const cams = this.stretch();
    const placed = cams.map((c) => this.editor.poseOf(c)).filter(Boolean);
    const step = meanStep(placed.map((p) => [p.x, p.y]));
    const laid = this.layout(cams.length, step, placed);
    if (!laid) return this.notify("Draw at least two corners (or drag out a circle) first.");
    this.editor.setPoses(new Map(cams.map((c, i) => [c.id, laid.poses[i]])));
    const how = laid.gap === step ? "the stretch's own step"
      : `evenly over the drawn path: ${step ? "at its own step the stretch would not fit" : "the stretch has no step"}`;
    this.stop(`Laid ${cams.length} cameras along the ${this.sketch.kind === "circle" ? "circle" : "path"}, ` +
      `${laid.gap.toPrecision(3)} units apart (${how}).`);
    Object.assign(this.root.dataset, { laid: String(cams.length), spacing: String(laid.gap), step: String(step ?? "") });
    return undefined;
  }

  // {poses, gap} for n cameras along the sketch, or null when it is not a path yet.
  layout(n, step, placed) {
    const yawMode = this.yaw.value;
    const s = this.sketch;
    if (s.kind === "circle") {
      if (!s.centre || !s.start || !(s.radius > 0)) return null;
      const startDeg = (Math.atan2(s.start[1] - s.centre[1], s.start[0] - s.centre[0]) * 180) / Math.PI;
      const direction = turnDirection(placed.map((p) => p.yaw_deg));
      const circle = { centre: s.centre, radius: s.radius, startDeg, direction };
      return { poses: alongCircle(circle, n, step, yawMode), gap: spacing(step, 2 * Math.PI * s.radius, n) };
    }
    if (s.points.length < 2) return null;
    return { poses: alongPolyline(s.points, n, step, yawMode), gap: spacing(step, pathLength(s.points), n - 1) };
  }

  stop(message) {
    this.store.tool = null;
    this.sketch = null;
    this.draw();
    this.show(message);
  }

  draw() { this.store.set("sketch", this.sketch ? { ...this.sketch } : null); }

  show(message) {
    this.status.textContent = message;
    const kind = this.store.tool?.kind ?? "";
    this.root.dataset.tool = kind;
    for (const [name, button] of Object.entries(this.buttons)) button.setAttribute("aria-pressed", String(name === kind));
  }

  refresh() {
    const n = this.store.selection.size;
    for (const button of Object.values(this.buttons)) button.disabled = !this.store.editable || n < 2;
    if (!this.store.tool) this.status.textContent ||= "Select a capture-order stretch, then draw its path.";
  }
}
