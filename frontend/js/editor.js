// Editing the draft: arrow keys translate the selection, q/r rotate it about its centroid (rigidly),
// mouse drag moves it, sliders set FoV and range, unregistered images are dropped into the scene.
// It changes the draft and the selection only; the panels see the changes through the store.
import { pick } from "./draft.js";
import { median, rigidMove } from "./geometry.js";

const STEP_OF_RANGE = 0.05; // one arrow press moves this share of the median camera range
const SHIFT = 5; // shift multiplies steps
const ROTATE_DEG = 2;

export class Editor {
  // centre(): the world point new images are placed at (the view's centre).
  constructor(store, draft, selection, notify, centre) {
    Object.assign(this, { store, draft, selection, notify, centre });
    const ranges = store.cameras.map((c) => c.range).filter((r) => r > 0);
    const fovs = store.cameras.map((c) => c.fov_deg).filter((f) => f > 0);
    this.medianRange = median(ranges) ?? 1;
    this.medianFov = median(fovs) ?? 60;
    this.step = this.medianRange * STEP_OF_RANGE;
    this.rotateStep = ROTATE_DEG;
  }

  // The pose on screen: the draft's when moved, else the model's, else (a camera of a split-off
  // model) its group pose; null when not placed.
  poseOf(cam) {
    const edit = this.draft.cameras.get(cam.id) ?? (cam.x === null ? cam.group : null);
    if (!edit) return cam.x === null ? null : cam;
    return { ...cam, ...edit, fov_deg: edit.fov_deg ?? cam.fov_deg ?? this.medianFov,
      range: edit.range ?? cam.range ?? this.medianRange };
  }

  // The pose the server's rule sees: the draft's or the model's (a group pose is only a proposal).
  editPose(cam) {
    return this.draft.cameras.has(cam.id) || cam.x !== null ? this.poseOf(cam) : null;
  }

  // Put poses (image id -> {x, y, yaw_deg}) into the draft as one undo step, each camera keeping
  // its frustum; returns whether anything changed.
  setPoses(poses, mergeKey = null) {
    const known = [...poses].filter(([id]) => this.store.byId.has(id));
    if (!this.canEdit() || !known.length) return false;
    this.draft.change((d) => {
      for (const [id, p] of known) {
        const now = this.poseOf(this.store.byId.get(id));
        d.cameras.set(id, { x: p.x, y: p.y, yaw_deg: p.yaw_deg,
          fov_deg: now?.fov_deg ?? this.medianFov, range: now?.range ?? this.medianRange });
      }
    }, mergeKey);
    return true;
  }

  canEdit() {
    if (this.store.editable) return true;
    let why = this.store.readOnly ? "this version is open read-only" : "a job of this project is running";
    if (!this.store.canWrite) why = "you are a viewer of this project (editing needs the editor role)";
    this.notify(`Editing is locked: ${why}.`, "warning");
    return false;
  }

  selectedPoses() {
    const out = [];
    for (const id of this.store.selection) {
      const pose = this.poseOf(this.store.byId.get(id));
      if (pose) out.push(pose);
    }
    return out;
  }

  // Translate by (dx, dy) and rotate by deg about the centroid, all selected cameras as one body.
  move(dx, dy, deg, mergeKey) {
    if (!this.canEdit()) return;
    const poses = this.selectedPoses();
    if (!poses.length) {
      this.notify("Select placed cameras first (unregistered images need dropping into the scene).");
      return;
    }
    this.draft.change((d) => {
      for (const p of rigidMove(poses, dx, dy, deg)) d.cameras.set(p.id, pick(p));
    }, mergeKey);
  }

  // A mouse drag: `poses` (taken when it started) translated by (dx, dy), one undo step.
  drag(poses, dx, dy, key) {
    this.draft.change((d) => {
      for (const p of poses) d.cameras.set(p.id, { ...pick(p), x: p.x + dx, y: p.y + dy });
    }, key, true);
  }

  // Set fov_deg and/or range on every selected, placed camera.
  setFrustum(values, mergeKey) {
    if (!this.canEdit()) return;
    const poses = this.selectedPoses();
    if (!poses.length) return;
    this.draft.change((d) => {
      for (const p of poses) d.cameras.set(p.id, pick({ ...p, ...values }));
    }, mergeKey);
  }

  // Place images (unregistered ones in particular) at a world point, spread along x.
  place(ids, x, y) {
    if (!this.canEdit() || !ids.length) return;
    this.draft.change((d) => {
      ids.forEach((id, i) => {
        const cam = this.store.byId.get(id);
        const old = this.poseOf(cam);
        d.cameras.set(id, { x: x + i * this.step * 4, y, yaw_deg: old?.yaw_deg ?? 90,
          fov_deg: cam.fov_deg ?? this.medianFov, range: cam.range ?? this.medianRange });
      });
    });
  }

  placeSelectionAtCentre() {
    const unplaced = [...this.store.selection].filter((id) => !this.poseOf(this.store.byId.get(id)));
    if (!unplaced.length) return this.notify("No selected image is waiting to be placed.");
    this.place(unplaced, ...this.centre());
  }

  resetSelected() {
    if (!this.canEdit()) return;
    const ids = [...this.store.selection].filter((id) => this.draft.cameras.has(id));
    if (ids.length) this.draft.change((d) => ids.forEach((id) => d.cameras.delete(id)));
  }

  toggleFlag() {
    if (!this.canEdit() || !this.store.selection.size) return;
    const ids = [...this.store.selection];
    const on = !ids.every((id) => this.draft.flags.has(id));
    this.draft.change((d) => ids.forEach((id) => (on ? d.flags.add(id) : d.flags.delete(id))));
  }

  // Keys of the loop; returns true when the key was ours.
  handleKey(e) {
    const mod = e.ctrlKey || e.metaKey;
    const big = e.shiftKey ? SHIFT : 1;
    const arrows = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
    if (arrows[e.key] && !mod && !e.altKey) {
      const [sx, sy] = arrows[e.key];
      this.move(sx * this.step * big, sy * this.step * big, 0, "move");
    } else if (!mod && (e.key === "q" || e.key === "Q")) this.move(0, 0, ROTATE_DEG * big, "rotate");
    else if (!mod && (e.key === "r" || e.key === "R")) this.move(0, 0, -ROTATE_DEG * big, "rotate");
    else if (mod && e.key.toLowerCase() === "z") (e.shiftKey ? this.redo() : this.undo());
    else if (mod && e.key.toLowerCase() === "y") this.redo();
    else if (mod && e.key.toLowerCase() === "a") this.selection.all();
    else if (e.key === "Escape") this.selection.clear();
    else if (e.key === "]" || e.key === "}") this.selection.step(1, e.shiftKey);
    else if (e.key === "[" || e.key === "{") this.selection.step(-1, e.shiftKey);
    else if (!mod && e.key.toLowerCase() === "f") this.toggleFlag();
    else if (!mod && e.key.toLowerCase() === "p") this.placeSelectionAtCentre();
    else return false;
    return true;
  }

  undo() { if (this.canEdit()) this.draft.undo(); }
  redo() { if (this.canEdit()) this.draft.redo(); }
}
