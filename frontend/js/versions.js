// Version history: author, time and stats of every version; open one read-only, restore it, or
// compare it with the version on screen (cameras that moved, drawn as arrows on the scene).
import { blobUrl, get, post } from "./api.js";
import { median } from "./geometry.js";

const MOVED_SHARE = 0.1; // of the median camera range: a camera farther than this has moved

export class VersionsPanel {
  constructor(root, { store, notify, onRestored }, signal) {
    Object.assign(this, { root, store, notify, onRestored });
    this.list = root.querySelector("#version-list");
    this.summary = root.querySelector("#compare-summary");
    this.clearButton = root.querySelector("#compare-clear");
    this.clearButton.addEventListener("click", () => this.clearCompare(), { signal });
    this.list.addEventListener("click", (e) => this.onClick(e), { signal });
    this.clearCompare();
  }

  get base() { return `/projects/${this.store.project.id}/versions`; }

  async load() {
    const versions = (await get(this.base)) ?? [];
    versions.sort((a, b) => b.id - a.id);
    this.versions = versions;
    this.list.replaceChildren(...versions.map((v) => this.row(v)));
    this.root.dataset.count = String(versions.length);
    return versions;
  }

  row(v) {
    const { project, version, locked } = this.store;
    const li = document.createElement("li");
    li.dataset.versionId = String(v.id);
    const isHead = v.id === project.head_version_id;
    const onScreen = v.id === version?.id;
    li.classList.toggle("head", isHead);
    li.classList.toggle("open", onScreen);
    const s = v.stats ?? {};
    const when = v.created_at ? new Date(v.created_at).toLocaleString() : "";
    const title = document.createElement("div");
    title.className = "version-title";
    title.textContent = `v${v.id} · ${v.kind ?? ""}${isHead ? " · head" : ""}${onScreen ? " · on screen" : ""}`;
    const meta = document.createElement("div");
    meta.className = "version-meta";
    meta.textContent = `${v.author ?? "?"}, ${when}`;
    const stats = document.createElement("div");
    stats.className = "version-stats";
    stats.textContent = `${s.num_registered ?? "?"}/${s.num_images ?? "?"} registered · ` +
      `${s.num_pairs ?? "?"} pairs · ${s.num_models ?? "?"} models · ${s.num_points ?? "?"} points`;
    li.append(title, meta, stats);
    if (v.message) {
      const message = document.createElement("div");
      message.className = "version-meta";
      message.textContent = v.message;
      li.append(message);
    }
    const actions = document.createElement("div");
    actions.className = "row";
    const openTitle = isHead ? "Open the head for editing" : "Open read-only";
    if (!onScreen) actions.append(button("Open", "open", v.id, openTitle));
    if (!isHead && this.store.canWrite) {
      actions.append(button("Restore", "restore", v.id, "Make a new head with this content", locked));
    }
    if (!onScreen) actions.append(button("Compare", "compare", v.id, "Arrows from it to the version on screen"));
    actions.append(button("Export COLMAP", "export-colmap", v.id, "Download its model (cameras.bin, images.bin, points3D.bin) as a zip"));
    actions.append(button("Export PLY", "export-ply", v.id, "Download its points with colours (binary PLY)"));
    li.append(actions);
    return li;
  }

  onClick(e) {
    const target = e.target.closest("button[data-action]");
    if (!target) return;
    const id = Number(target.dataset.versionId);
    if (target.dataset.action === "open") {
      const head = id === this.store.project.head_version_id;
      location.hash = head ? `#/p/${this.store.project.id}` : `#/p/${this.store.project.id}/v/${id}`;
    } else if (target.dataset.action === "restore") this.restore(id);
    else if (target.dataset.action.startsWith("export-")) this.exportAs(id, target.dataset.action.slice(7));
    else this.compare(id);
  }

  // Download an export: fetched with the token (a plain link cannot send it), saved by a link.
  async exportAs(id, format) {
    try {
      const url = await blobUrl(`${this.base}/${id}/export?format=${format}`);
      const a = document.createElement("a");
      a.href = url;
      a.download = `${this.store.project.name}-v${id}.${format === "ply" ? "ply" : "zip"}`;
      document.body.append(a);
      a.click();
      a.remove();
      setTimeout(() => URL.revokeObjectURL(url), 60000);
      this.notify(`Exported v${id} (${format === "ply" ? "PLY points" : "COLMAP model"}).`);
    } catch (error) {
      this.notify(`Could not export v${id}: ${error.message}`, "error");
    }
  }

  async restore(id) {
    try {
      const version = await post(`${this.base}/${id}/restore`);
      this.notify(`Restored v${id} as the new head v${version.id}.`);
      this.onRestored(version);
    } catch (error) {
      this.notify(`Could not restore v${id}: ${error.message}`, "error");
    }
  }

  async compare(otherId) {
    const current = this.store.version.id;
    try {
      const [result, scene] = await Promise.all([
        get(`${this.base}/${otherId}/compare?to=${current}`),
        get(`${this.base}/${otherId}/scene`),
      ]);
      this.showArrows(otherId, result, scene);
    } catch (error) {
      this.notify(`Could not compare v${otherId} with v${current}: ${error.message}`, "error");
    }
  }

  // Arrows from each camera's place in the other version to its place on screen. /compare says
  // which cameras moved (after aligning the two models); the arrows need no fit of their own, as
  // a version's model is aligned to its parent's when it is made, so both share one world frame
  // and the other version's camera centres are only projected onto the ground frame on screen.
  // A fresh reconstruction is not aligned to earlier versions: when the cameras the server calls
  // unmoved are not where they were, no arrows are drawn and the summary says why.
  showArrows(otherId, result, scene) {
    const { frame, medianRange } = this.store;
    const project = (c) => {
      const d = c.map((v, i) => v - frame.origin[i]);
      return [dot(d, frame.x_axis), dot(d, frame.y_axis)];
    };
    const before = new Map(scene.cameras.filter((c) => c.center).map((c) => [c.image_id, project(c.center)]));
    const changes = new Map(result.cameras.map((c) => [c.image_id, c]));
    const common = this.store.cameras.filter((c) => c.x !== null && before.has(c.id));
    const moved = common.filter((c) => isMoved(changes.get(c.id), medianRange));
    const still = common.filter((c) => !moved.includes(c) && typeof changes.get(c.id)?.moved === "number");
    const offsets = still.map((c) => Math.hypot(before.get(c.id)[0] - c.x, before.get(c.id)[1] - c.y));
    const shared = !offsets.length || median(offsets) <= MOVED_SHARE * medianRange;
    const arrows = shared ? moved.map((c) => ({ id: c.id, from: before.get(c.id), to: [c.x, c.y] })) : [];
    this.store.set("arrows", arrows);
    Object.assign(this.summary.dataset, { moved: String(moved.length), arrows: JSON.stringify(arrows),
      sharedFrame: String(shared) });
    this.summary.textContent = `v${otherId} → v${this.store.version.id}: ${moved.length} of ${common.length} ` +
      (shared ? "cameras moved (arrows)." : `cameras moved; v${otherId} is in another frame (a separate ` +
        "reconstruction), so no arrows are drawn.") + movedNames(moved);
    this.clearButton.hidden = false;
  }

  clearCompare() {
    this.store.set("arrows", []);
    this.summary.textContent = "";
    delete this.summary.dataset.moved;
    delete this.summary.dataset.arrows;
    delete this.summary.dataset.sharedFrame;
    this.clearButton.hidden = true;
  }
}

// " Moved: #3 0002.jpg, #4 0003.jpg, …": which cameras, in capture order (at most a dozen named).
function movedNames(moved) {
  if (!moved.length) return "";
  const named = [...moved].sort((a, b) => a.seq - b.seq).slice(0, 12).map((c) => `#${c.seq + 1} ${c.name}`);
  return ` Moved: ${named.join(", ")}${moved.length > 12 ? `, and ${moved.length - 12} more` : ""}.`;
}

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

// Moved: farther than a tenth of the median camera range, or turned more than 5 degrees.
function isMoved(change, medianRange) {
  if (!change) return false;
  const distance = typeof change.moved === "number" ? change.moved : change.moved ? Infinity : 0;
  return distance > MOVED_SHARE * medianRange || (change.rotated_deg ?? 0) > 5;
}

function button(text, action, versionId, title, disabled = false) {
  const b = document.createElement("button");
  b.type = "button";
  b.textContent = text;
  b.title = title;
  b.disabled = disabled;
  b.dataset.action = action;
  b.dataset.versionId = String(versionId);
  return b;
}
