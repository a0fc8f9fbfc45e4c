// The image-sequence strip: thumbnails in capture order, linked to the scene by hover and selection.
import { DRAG_IMAGE } from "./state.js";
import { ThumbnailLoader } from "./thumbs.js";

export class Strip {
  constructor(root, { store, selection, draft, projectId }, signal) {
    Object.assign(this, { root, store, selection, draft });
    this.loader = new ThumbnailLoader(projectId, root);
    this.buttons = new Map();
    this.render();
    root.addEventListener("click", (e) => this.onClick(e), { signal });
    root.addEventListener("pointerover", (e) => this.onHover(this.idOf(e.target)), { signal });
    root.addEventListener("pointerleave", () => this.onHover(null), { signal });
    root.addEventListener("dragstart", (e) => {
      const id = this.idOf(e.target);
      if (id !== null) e.dataTransfer.setData(DRAG_IMAGE, String(id));
    }, { signal });
    store.on("selection", () => this.update(true));
    store.on("hover", () => this.updateHover());
    store.on("draft", () => this.update(false));
  }

  render() {
    this.root.replaceChildren();
    for (const cam of this.store.cameras) {
      const button = document.createElement("button");
      button.type = "button";
      button.className = "thumb";
      button.dataset.id = String(cam.id);
      button.dataset.seq = String(cam.seq);
      button.tabIndex = -1;
      button.title = `${cam.name} (#${cam.seq + 1})`;
      button.draggable = true;
      const img = document.createElement("img");
      img.alt = "";
      const label = document.createElement("span");
      label.textContent = cam.name;
      button.append(img, label);
      this.root.append(button);
      this.buttons.set(cam.id, button);
      this.loader.observe(img, cam.id);
    }
    const first = this.buttons.values().next().value;
    if (first) first.tabIndex = 0;
    this.update(false);
  }

  idOf(target) {
    const button = target.closest?.(".thumb");
    return button ? Number(button.dataset.id) : null;
  }

  onClick(e) {
    const id = this.idOf(e.target);
    if (id === null) return;
    // Enter/Space on a focused thumbnail arrive here too (e.detail === 0), with their modifiers.
    this.selection.click(id, { shift: e.shiftKey, toggle: e.ctrlKey || e.metaKey });
  }

  onHover(id) {
    if (this.store.hovered === id) return;
    this.store.hovered = id;
    this.store.emit("hover");
  }

  update(moveFocus) {
    const { selection, byId } = this.store;
    for (const [id, button] of this.buttons) {
      const cam = byId.get(id);
      button.setAttribute("aria-pressed", String(selection.has(id)));
      button.classList.toggle("moved", this.draft.cameras.has(id));
      button.classList.toggle("flagged", this.draft.flags.has(id));
      button.classList.toggle("unregistered", cam.registered === false);
      button.classList.toggle("placed", cam.registered === false && this.draft.cameras.has(id));
    }
    this.root.dataset.selected = [...selection].join(",");
    const focusId = this.store.lastStepped ?? this.store.anchor;
    const target = this.buttons.get(focusId);
    if (!target) return;
    for (const button of this.buttons.values()) button.tabIndex = button === target ? 0 : -1;
    if (moveFocus && this.root.contains(document.activeElement) && document.activeElement !== target) {
      target.focus();
    }
    if (moveFocus) target.scrollIntoView({ block: "nearest", inline: "nearest" });
  }

  updateHover() {
    const id = this.store.hovered;
    this.root.querySelector(".thumb.hovered")?.classList.remove("hovered");
    const button = this.buttons.get(id);
    if (!button) return;
    button.classList.add("hovered");
    if (!this.root.matches(":hover")) button.scrollIntoView({ block: "nearest", inline: "nearest" });
  }
}
