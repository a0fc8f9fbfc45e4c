// Selecting images: single, toggle (ctrl/cmd), range in capture order (shift), all, step by seq.

export class Selection {
  constructor(store) {
    this.store = store;
  }

  get ordered() { return this.store.cameras; } // the scene lists cameras in capture order

  set(ids, anchor = this.store.anchor) {
    this.store.selection = new Set(ids);
    this.store.anchor = anchor;
    this.store.emit("selection");
  }

  // A click with modifiers: plain selects one, ctrl/cmd toggles, shift extends from the anchor.
  click(id, { shift = false, toggle = false } = {}) {
    const current = this.store.selection;
    if (shift && this.store.anchor !== null) {
      const ids = this.range(this.store.anchor, id);
      this.set(toggle ? [...current, ...ids] : ids, this.store.anchor);
    } else if (toggle) {
      const next = new Set(current);
      if (next.has(id)) next.delete(id);
      else next.add(id);
      this.set(next, id);
    } else {
      this.set([id], id);
    }
    this.store.lastStepped = id;
  }

  range(fromId, toId) {
    const seqOf = (id) => this.store.byId.get(id)?.seq ?? 0;
    const [lo, hi] = [seqOf(fromId), seqOf(toId)].sort((a, b) => a - b);
    return this.ordered.filter((c) => c.seq >= lo && c.seq <= hi).map((c) => c.id);
  }

  // The cameras of the split-off model `id` belongs to (drawn at their group pose, moved as one
  // piece); empty for a camera of the largest model.
  groupOf(id) {
    const cam = this.store.byId.get(id);
    if (!cam?.group || cam.model === null) return [];
    return this.ordered.filter((c) => c.group && c.model === cam.model).map((c) => c.id);
  }

  selectGroup(id) {
    const ids = this.groupOf(id);
    if (!ids.length) return;
    this.set(ids, id);
    this.store.lastStepped = id;
  }

  all() { this.set(this.ordered.map((c) => c.id)); }
  clear() { this.set([], null); }

  // Keyboard: the next/previous image in capture order; extend keeps the anchor.
  step(delta, extend) {
    const list = this.ordered;
    if (!list.length) return null;
    const last = this.store.lastStepped ?? this.store.anchor;
    const index = list.findIndex((c) => c.id === last);
    const next = list[Math.min(list.length - 1, Math.max(0, index < 0 ? 0 : index + delta))];
    if (extend && this.store.anchor !== null) this.set(this.range(this.store.anchor, next.id));
    else this.set([next.id], next.id);
    this.store.lastStepped = next.id;
    return next.id;
  }
}
