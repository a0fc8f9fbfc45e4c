// Keeps the server's edit set in step with the draft: debounced POST/PUT with If-Match, then GET
// .../preview. No change is dropped without a notice: a 409 (someone saved first) merges this
// page's changes onto theirs and saves again; a new draft joins an edit set another tab or user
// started on the same version; an edit set left on an older version is rebased onto the head on
// opening, with a report of what was carried; a change the server refuses is undone on screen.
import { ApiError, get, post, request } from "./api.js";
import { pairKey } from "./geometry.js";

const DEBOUNCE_MS = 400;
const EMPTY = { cameras: [], delete_pairs: [], flags: [], rule: "default" };

export class DraftSync {
  constructor(store, draft, notify) {
    this.store = store;
    this.draft = draft;
    this.notify = notify;
    this.editId = null;
    this.revision = null;
    this.kept = null; // the body the server has (what a refused change falls back to)
    this.changes = 0; // bumped on every local change
    this.saved = 0; // the change count the server has
    this.timer = 0;
    this.running = null;
    this.store.preview = null;
    this.store.previewState = "none";
  }

  get base() { return `/projects/${this.store.project.id}/edits`; }

  // Resume the newest edit set on the version on screen; else carry the newest one left on an
  // older version onto it (the head), saying what could not be carried.
  async attach() {
    const list = (await get(this.base)) ?? [];
    const here = newest(list.filter((e) => e.base_version_id === this.store.version.id));
    // an edit set whose revision was applied made a version already: it is not carried again
    const stale = newest(list.filter((e) => e.base_version_id < this.store.version.id && !e.applied_version_id));
    if (here) this.adopt(await get(`${this.base}/${here.id}`));
    else if (stale && this.store.canWrite && this.store.version.id === this.store.project.head_version_id) {
      await this.rebase(stale);
    } else return this.setPreview(null, "none");
    await this.fetchPreview();
  }

  adopt(editSet) {
    this.editId = editSet.id;
    this.revision = editSet.revision;
    this.kept = editSet;
    this.draft.load(editSet);
  }

  async rebase(stale) {
    const { data } = await request("POST", `${this.base}/${stale.id}/rebase`,
      { headers: { "If-Match": String(stale.revision) } });
    this.adopt(data);
    this.store.rebaseReport = data.report;
    this.notify(rebaseText(data.report, this.store.byId), data.report.dropped.length ? "warning" : "info");
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
      if (error instanceof ApiError && error.status === 409) await this.mergeAfterConflict(upTo);
      else this.undoRefused(error);
    }
  }

  // The server refused the change: put the scene back to what it keeps and say so, so nothing
  // on screen pretends to be saved. A 403 means our role is now viewer.
  undoRefused(error) {
    this.notify(`Your change was not kept: ${error.message}. The scene shows the saved edits again.`,
      "error");
    this.saved = this.changes;
    this.draft.load(this.kept ?? EMPTY);
    this.setPreview(this.kept ? this.store.preview : null, this.kept ? "ready" : "none");
    if (error instanceof ApiError && error.status === 403) this.store.set("role", "viewer");
  }

  async save() {
    const body = this.draft.body(this.store.version.id);
    if (this.editId === null) {
      const list = (await get(this.base)) ?? [];
      const other = newest(list.filter((e) => e.base_version_id === this.store.version.id));
      if (other) return this.joinOther(await get(`${this.base}/${other.id}`));
      const created = await post(this.base, body);
      this.editId = created.id;
      this.revision = created.revision;
      this.kept = body;
      return undefined;
    }
    return this.put(body);
  }

  async put(body) {
    const headers = { "If-Match": String(this.revision) };
    const { data, response } = await request("PUT", `${this.base}/${this.editId}`, { json: body, headers });
    this.revision = data?.revision ?? Number(response.headers.get("ETag")?.replaceAll('"', ""));
    this.kept = body;
  }

  // Another tab or user started an edit set on this version meanwhile: ours joins it.
  async joinOther(theirs) {
    const merged = mergeOnto(theirs, EMPTY, this.draft.body(this.store.version.id));
    this.adopt(theirs);
    this.draft.load(merged);
    await this.put(merged);
    this.notify(`${theirs.updated_by ?? "Someone"} had started edits on this version (another tab or ` +
      "person); your changes were merged into them and saved.", "warning");
  }

  // Someone saved a newer revision first: lay this page's changes since our last save over theirs
  // and save that; if even that is refused, say that the change was not kept.
  async mergeAfterConflict(upTo) {
    const current = await get(`${this.base}/${this.editId}`);
    const who = current.updated_by ?? "Someone";
    const when = current.updated_at ? new Date(current.updated_at).toLocaleTimeString() : "just now";
    const merged = mergeOnto(current, this.kept ?? EMPTY, this.draft.body(this.store.version.id));
    this.adopt(current);
    this.draft.load(merged); // on screen before the save: keys pressed meanwhile build on the merge
    try {
      await this.put(merged);
      this.notify(`${who} changed these edits at ${when}; your change was merged onto theirs and saved.`,
        "warning");
    } catch (error) {
      this.draft.load(current);
      this.notify(`${who} changed these edits at ${when}; your last change was not kept ` +
        `(${error.message}). Their version is on screen.`, "error");
    }
    this.saved = Math.max(this.saved, upTo);
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

const newest = (list) => [...list].sort((a, b) => (b.updated_at ?? "").localeCompare(a.updated_at ?? ""))[0];

// A camera edit in the contract's fields only: the server's copy carries no others today, but
// the request refuses unknown fields, and equal edits must compare equal.
const cameraEdit = (c) => ({ image_id: c.image_id, x: c.x, y: c.y, yaw_deg: c.yaw_deg,
  fov_deg: c.fov_deg ?? null, range: c.range ?? null });

// `mine` differs from `kept` (what the server had when we last saved) by this page's changes:
// apply just those to `theirs`, a newer body, so neither side's work is lost. The result is a
// request body: none of the server's answer fields (id, revision, updated_by, ...) which a PUT
// refuses with 422.
export function mergeOnto(theirs, kept, mine) {
  const byId = (body) => new Map((body.cameras ?? []).map((c) => [c.image_id, cameraEdit(c)]));
  const [cameras, before, now] = [byId(theirs), byId(kept), byId(mine)];
  for (const [id, cam] of now) if (JSON.stringify(cam) !== JSON.stringify(before.get(id))) cameras.set(id, cam);
  for (const id of before.keys()) if (!now.has(id)) cameras.delete(id);
  const keys = (body) => new Set((body.delete_pairs ?? []).map(([a, b]) => pairKey(a, b)));
  const pairs = applyDelta(keys(theirs), keys(kept), keys(mine));
  const flags = applyDelta(new Set(theirs.flags ?? []), new Set(kept.flags ?? []), new Set(mine.flags ?? []));
  return { base_version_id: mine.base_version_id, cameras: [...cameras.values()],
    delete_pairs: [...pairs].map((k) => k.split("-").map(Number)), flags: [...flags],
    rule: (mine.rule ?? "default") !== (kept.rule ?? "default") ? mine.rule : theirs.rule ?? "default",
    tolerances: theirs.tolerances ?? {} };
}

function applyDelta(theirs, before, now) {
  const out = new Set(theirs);
  for (const x of now) if (!before.has(x)) out.add(x);
  for (const x of before) if (!now.has(x)) out.delete(x);
  return out;
}

// "Your edits from v3 are now on the head v5: 4 cameras, 1 deletion carried; not carried: ..."
function rebaseText(report, byId) {
  const c = report.carried;
  const name = (id) => byId.get(id)?.name ?? `#${id}`;
  const dropped = report.dropped.map((d) => `${d.kind.replace("_", " ")} ${d.image_ids.map(name).join("–")} ` +
    `(${d.reason})`);
  return `Edits made on v${report.from_version} were carried onto the head v${report.to_version}: ` +
    `${c.cameras.length} camera(s), ${c.delete_pairs.length} deletion(s), ${c.flags.length} flag(s).` +
    (dropped.length ? ` Not carried: ${dropped.join("; ")}.` : " Nothing was left behind.");
}
