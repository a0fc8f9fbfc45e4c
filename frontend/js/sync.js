// Keeps the server's edit set in step with the draft: debounced POST/PUT with If-Match, a 409
// reloads the server's copy, and every save is followed by GET .../preview.
import { ApiError, get, post, request } from "./api.js";

const DEBOUNCE_MS = 400;

export class DraftSync {
  constructor(store, draft, notify) {
    this.store = store;
    this.draft = draft;
    this.notify = notify;
    this.editId = null;
    this.revision = null;
    this.changes = 0; // bumped on every local change
    this.saved = 0; // the change count the server has
    this.timer = 0;
    this.running = null;
    this.store.preview = null;
    this.store.previewState = "none";
  }

  get base() { return `/projects/${this.store.project.id}/edits`; }

  // Resume the newest edit set on the version on screen, if there is one.
  async attach() {
    const list = await get(this.base);
    const mine = (list ?? []).filter((e) => e.base_version_id === this.store.version.id)
      .sort((a, b) => (b.updated_at ?? "").localeCompare(a.updated_at ?? ""))[0];
    if (!mine) return this.setPreview(null, "none");
    const full = await get(`${this.base}/${mine.id}`);
    this.editId = full.id;
    this.revision = full.revision;
    this.draft.load(full);
    this.kept = full;
    await this.fetchPreview();
  }

  changed() {
    this.changes += 1;
    this.setPreview(this.store.preview, "stale");
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.flush(), DEBOUNCE_MS);
  }

  // Save now (waiting for a save under way) and fetch the preview; resolves when both are done.
  async flush() {
    clearTimeout(this.timer);
    while (this.running) await this.running;
    if (this.saved === this.changes && this.store.previewState !== "stale") return;
    this.running = this.saveAndPreview().finally(() => { this.running = null; });
    await this.running;
  }

  async saveAndPreview() {
    const upTo = this.changes;
    try {
      if (this.editId === null && this.draft.empty) {
        this.saved = upTo;
        return this.setPreview(null, "none");
      }
      await this.save();
      this.saved = upTo;
      await this.fetchPreview();
    } catch (error) {
      if (error instanceof ApiError && error.status === 409) await this.reloadAfterConflict();
      else this.undoRefused(error);
    }
  }

  // The server refused the change: put the scene back to what it keeps and say so, so nothing
  // on screen pretends to be saved. A 403 means our role is now viewer.
  undoRefused(error) {
    this.notify(`Your change was not kept: ${error.message}. The scene shows the saved edits again.`,
      "error");
    this.saved = this.changes;
    this.draft.load(this.kept ?? { cameras: [], delete_pairs: [], flags: [] });
    this.setPreview(this.kept ? this.store.preview : null, this.kept ? "ready" : "none");
    if (error instanceof ApiError && error.status === 403) this.store.set("role", "viewer");
  }

  async save() {
    const body = this.draft.body(this.store.version.id);
    if (this.editId === null) {
      const created = await post(this.base, body);
      this.editId = created.id;
      this.revision = created.revision;
      this.kept = body;
      return;
    }
    const headers = { "If-Match": String(this.revision) };
    const { data, response } = await request("PUT", `${this.base}/${this.editId}`, { json: body, headers });
    this.revision = data?.revision ?? Number(response.headers.get("ETag")?.replaceAll('"', ""));
    this.kept = body;
  }

  async reloadAfterConflict() {
    const current = await get(`${this.base}/${this.editId}`);
    const when = current.updated_at ? new Date(current.updated_at).toLocaleTimeString() : "just now";
    this.notify(`${current.updated_by ?? "Someone"} changed these edits at ${when}; ` +
      "their version is loaded (your last change was not saved).", "warning");
    this.revision = current.revision;
    this.kept = current;
    this.draft.load(current);
    this.saved = this.changes;
    await this.fetchPreview();
  }

  async fetchPreview() {
    if (this.editId === null) return this.setPreview(null, "none");
    const preview = await get(`${this.base}/${this.editId}/preview`);
    this.setPreview(preview, this.saved === this.changes ? "ready" : "stale");
  }

  setPreview(preview, state) {
    this.store.preview = preview;
    this.store.previewState = state;
    this.store.emit("preview");
  }
}
