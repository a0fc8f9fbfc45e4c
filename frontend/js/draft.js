// The draft edit set in the browser: moved cameras, manual pair deletions and flags, with undo/redo.
import { pairKey, splitKey } from "./geometry.js";

const MERGE_MS = 700; // repeated key presses of one kind within this time are one undo step

// A pose's fields that an edit set stores for a moved camera.
export const pick = (p) => ({ x: p.x, y: p.y, yaw_deg: p.yaw_deg, fov_deg: p.fov_deg, range: p.range });

export class Draft {
  constructor() {
    this.cameras = new Map(); // image id -> {x, y, yaw_deg, fov_deg, range}
    this.deletePairs = new Set(); // pairKey strings
    this.flags = new Set();
    this.rule = "default";
    this.undoStack = [];
    this.redoStack = [];
    this.lastMerge = { key: null, at: 0 };
    this.onChange = () => {};
  }

  get empty() {
    return !this.cameras.size && !this.deletePairs.size && !this.flags.size;
  }

  snapshot() {
    return { cameras: new Map([...this.cameras].map(([id, p]) => [id, { ...p }])),
      deletePairs: new Set(this.deletePairs), flags: new Set(this.flags) };
  }

  restore(snap) {
    this.cameras = snap.cameras;
    this.deletePairs = snap.deletePairs;
    this.flags = snap.flags;
  }

  // Apply mutate(draft); changes with the same mergeKey in quick succession share one undo step.
  // A drag passes hold = true: all its moves are one step however slow it is.
  change(mutate, mergeKey = null, hold = false) {
    const now = performance.now();
    const merge = mergeKey && this.lastMerge.key === mergeKey && (hold || now - this.lastMerge.at < MERGE_MS);
    if (!merge) this.undoStack.push(this.snapshot());
    this.redoStack = [];
    this.lastMerge = { key: mergeKey, at: now };
    mutate(this);
    this.onChange("edit");
  }

  undo() { this.step(this.undoStack, this.redoStack); }
  redo() { this.step(this.redoStack, this.undoStack); }

  step(from, to) {
    if (!from.length) return;
    to.push(this.snapshot());
    this.restore(from.pop());
    this.lastMerge = { key: null, at: 0 };
    this.onChange("history");
  }

  togglePairs(keys, deleted) {
    for (const key of keys) (deleted ? this.deletePairs.add(key) : this.deletePairs.delete(key));
  }

  // The contract's edit-set body.
  body(baseVersionId) {
    return {
      base_version_id: baseVersionId,
      cameras: [...this.cameras].map(([id, p]) => ({ image_id: id, x: p.x, y: p.y, yaw_deg: p.yaw_deg,
        fov_deg: p.fov_deg, range: p.range })),
      delete_pairs: [...this.deletePairs].map(splitKey),
      flags: [...this.flags],
      rule: this.rule,
    };
  }

  // Replace everything with an edit set from the server; the history starts again.
  load(editSet) {
    this.cameras = new Map((editSet.cameras ?? []).map((c) => [c.image_id,
      { x: c.x, y: c.y, yaw_deg: c.yaw_deg, fov_deg: c.fov_deg ?? null, range: c.range ?? null }]));
    this.deletePairs = new Set((editSet.delete_pairs ?? []).map(([a, b]) => pairKey(a, b)));
    this.flags = new Set(editSet.flags ?? []);
    this.rule = editSet.rule ?? "default";
    this.undoStack = [];
    this.redoStack = [];
    this.onChange("load");
  }
}
