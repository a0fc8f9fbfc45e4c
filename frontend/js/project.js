// The project page: loads a version's scene, pairs and edit set, builds the shared state (store,
// draft, selection, editor) and the panels, and wires the store's events to the scene view. The
// only module that imports panels: they never import each other.
import { ActivityPanel } from "./activity.js";
import { get, post } from "./api.js";
import { Draft } from "./draft.js";
import { Editor } from "./editor.js";
import { TERMINAL } from "./jobs.js";
import { MatchesPanel } from "./matches.js";
import { MembersPanel } from "./members.js";
import { bindPointer } from "./pointer.js";
import { Preview } from "./preview.js";
import { PathTool } from "./pathtool.js";
import { SceneView } from "./scene.js";
import { Selection } from "./selection.js";
import { adjacency, camerasOf, createStore, pointsOf } from "./state.js";
import { Strip } from "./strip.js";
import { DraftSync } from "./sync.js";
import { TeamPanel } from "./team.js";
import { TriagePanel } from "./triage.js";
import { View3D } from "./view3d.js";
import { bindControls } from "./controls.js";
import { UploadPanel } from "./upload.js";
import { VersionsPanel } from "./versions.js";

let view = null; // one SceneView per canvas, kept across pages
const JOB_LOOK_MS = 15000;

export class ProjectPage {
  constructor(root, { jobStatus, notify, username }) {
    Object.assign(this, { root, jobStatus, notify, username });
    this.abort = new AbortController();
    this.store = createStore();
    this.draft = new Draft();
  }

  close() {
    this.abort.abort();
    this.jobStatus.stop();
    clearTimeout(this.jobTimer);
    clearTimeout(this.sync?.timer);
  }

  async open(projectId, versionId = null) {
    const { store } = this;
    store.project = await get(`/projects/${projectId}`);
    store.role = store.project.role ?? null;
    const vid = versionId ?? store.project.head_version_id;
    store.readOnly = versionId !== null && versionId !== store.project.head_version_id;
    view ??= new SceneView(this.root.querySelector("#scene"));
    this.view = view;
    if (vid !== null && vid !== undefined) await this.loadVersion(projectId, vid);
    else await this.loadEmpty(projectId);
    this.wire();
    this.showBanner(null);
    await Promise.all([this.versions?.load(), this.loadMembers(), this.watchRunningJob()]);
    if (this.sync && !store.readOnly) await this.sync.attach();
    await Promise.all([this.team.poll(), this.activity.load().catch(() => {})]);
    this.refresh();
  }

  async loadVersion(projectId, vid) {
    const base = `/projects/${projectId}/versions/${vid}`;
    const [version, scene, pairs] = await Promise.all([
      get(`/projects/${projectId}/versions`).then((all) => all.find((v) => v.id === vid)),
      get(`${base}/scene`), get(`${base}/pairs`)]);
    if (!version) throw new Error(`version ${vid} does not exist in this project`);
    this.setScene(version, scene, pairs);
    this.loadMorePoints(base, scene); // not awaited: the first draw does not wait for it
  }

  // The server sends its own level of detail of the point layer (a big scene: a decimated one,
  // points.total says how many it keeps); the rest follows once the scene is drawn.
  async loadMorePoints(base, scene) {
    const { total, xy } = scene.points ?? {};
    if (!total || total <= (xy?.length ?? 0)) return;
    const { version } = this.store;
    const fuller = await get(`${base}/scene?max_points=${total}`).catch(() => null);
    if (!fuller || this.store.version !== version) return; // another version opened meanwhile
    this.store.points = pointsOf(fuller);
    this.view.points = this.store.points;
    this.view.requestDraw();
  }

  setScene(version, scene, pairs) {
    const { store } = this;
    store.version = version;
    store.frame = scene.frame;
    store.cameras = camerasOf(scene);
    store.byId = new Map(store.cameras.map((c) => [c.id, c]));
    store.points = pointsOf(scene);
    store.pairs = adjacency(pairs ?? []);
    this.view.setScene(store.cameras, store.points);
    this.view.fit();
    this.root.querySelector("#empty-scene").hidden = true;
  }

  // A project without a version: the strip shows the uploaded images, the scene stays empty.
  async loadEmpty(projectId) {
    const images = (await get(`/projects/${projectId}/images`)) ?? [];
    const { store } = this;
    store.version = null;
    store.cameras = images.sort((a, b) => a.seq - b.seq).map((img, i) => ({ id: img.id, name: img.name,
      seq: img.seq ?? i, registered: null, x: null, y: null, yaw_deg: null, fov_deg: null, range: null }));
    store.byId = new Map(store.cameras.map((c) => [c.id, c]));
    this.view.setScene(store.cameras, new Float32Array(0));
    this.view.requestDraw();
    this.root.querySelector("#empty-scene").hidden = false;
    this.root.querySelector("#images-panel").open = true;
  }

  wire() {
    const { store, draft, view, notify } = this;
    const signal = this.abort.signal;
    const selection = new Selection(store);
    this.selection = selection;
    this.editor = new Editor(store, draft, selection, notify, () => [view.view.cx, view.view.cy]);
    store.medianRange = this.editor.medianRange;
    this.wireView();
    const ctx = { store, draft, editor: this.editor, selection, projectId: store.project.id, notify };
    this.strip = new Strip(this.root.querySelector("#strip"), ctx, signal);
    this.preview = new Preview(this.root.querySelector("#preview-panel"), ctx);
    this.matches = new MatchesPanel(this.root.querySelector("#matching-panel"), ctx, signal);
    this.triage = new TriagePanel(this.root.querySelector("#triage-panel"), ctx, signal);
    this.triage.load(); // in the background: the page does not wait for the suspects
    this.pathTool = new PathTool(this.root.querySelector("#path-panel"), ctx, signal);
    if (store.version) {
      this.versions = new VersionsPanel(this.root.querySelector("#versions-panel"),
        { ...ctx, onRestored: () => this.reopen() }, signal);
      this.sync = new DraftSync(store, draft, notify);
    }
    this.upload = new UploadPanel(this.root.querySelector("#images-panel"), { ...ctx,
      onUploaded: () => { if (!store.version) this.reopen(); }, onJob: (job) => this.followJob(job) }, signal);
    this.wireTeam(ctx, signal);
    bindPointer(view.canvas, { ...ctx, view }, signal);
    const page = { flush: () => this.sync?.flush(), apply: () => this.apply() };
    this.controls = bindControls(this.root, { ...ctx, page }, signal);
    draft.onChange = (kind) => {
      store.emit("draft");
      if (kind !== "load") this.sync?.changed();
    };
    for (const name of ["draft", "selection", "preview", "display"]) store.on(name, () => this.refresh());
    store.on("role", () => { this.showBanner(null); this.refresh(); });
  }

  // Comments, review and presence (polled), and the activity feed, refreshed with each poll.
  wireTeam(ctx, signal) {
    this.team = new TeamPanel(this.root.querySelector("#team-panel"), { ...ctx, view: this.view,
      username: this.username, editSetId: () => this.sync?.editId ?? null,
      flush: () => this.sync?.flush() }, signal);
    this.activity = new ActivityPanel(this.root.querySelector("#activity-panel"), ctx, signal);
    this.team.afterPoll = () => this.activity.load().catch(() => {});
    this.view3d = new View3D(this.root, { ...ctx, projectId: this.store.project.id }, signal);
  }

  // The scene view draws what the store's events say; it is kept across pages, so it starts clean.
  wireView() {
    const { store, editor, view } = this;
    view.poseOf = (cam) => editor.poseOf(cam);
    view.setLines([]);
    view.setArrows([]);
    view.setGhosts([]);
    view.setSketch(null);
    store.showFrusta = view.showFrusta; // the display toggles outlive the page, like the view
    store.showOrder = view.showOrder;
    store.metresPerUnit = Number(localStorage.getItem(`gsfm.scale.${store.project.id}`)) || null;
    view.metresPerUnit = store.metresPerUnit;
    Object.assign(view.canvas.dataset, { step: String(editor.step), rotateStep: String(editor.rotateStep) });
    store.on("hover", () => { view.hovered = store.hovered; view.requestDraw(); });
    store.on("lines", (lines) => view.setLines(lines));
    store.on("arrows", (arrows) => view.setArrows(arrows));
    store.on("ghosts", (ghosts) => view.setGhosts(ghosts));
    store.on("sketch", (sketch) => view.setSketch(sketch));
    store.on("display", () => {
      Object.assign(view, { showFrusta: store.showFrusta, showOrder: store.showOrder,
        metresPerUnit: store.metresPerUnit });
      view.requestDraw();
    });
    store.on("view", (command) => view.command(command));
  }

  // Redraw the scene and the panels that depend on the draft, selection and preview.
  refresh() {
    const { store, draft, view } = this;
    view.selected = store.selection;
    view.moved = new Set(draft.cameras.keys());
    view.flagged = draft.flags;
    this.preview.refresh();
    this.matches.render();
    this.controls?.refresh();
    this.pathTool?.refresh();
    const canvas = view.canvas;
    canvas.dataset.selected = [...store.selection].join(",");
    canvas.dataset.moved = [...draft.cameras.keys()].join(",");
    canvas.dataset.versionId = String(store.version?.id ?? "");
    canvas.dataset.editable = String(store.editable);
    this.root.dataset.role = store.role ?? "";
    this.jobStatus.canCancel = store.canWrite;
  }

  async loadMembers() {
    const panel = this.root.querySelector("#members-panel");
    const role = this.store.project.role;
    panel.hidden = true;
    if (role && role !== "owner") return;
    try {
      const members = new MembersPanel(panel, { projectId: this.store.project.id, notify: this.notify },
        this.abort.signal);
      const list = await members.load();
      panel.hidden = list.find((m) => m.username === this.username)?.role !== "owner";
    } catch {
      panel.hidden = true;
    }
  }

  // Follow a job of this project that is under way, and look again every so often for one
  // that someone else starts.
  async watchRunningJob(first = true) {
    if (this.abort.signal.aborted || this.store.locked) return;
    const jobs = (await get(`/projects/${this.store.project.id}/jobs`)) ?? [];
    const running = jobs.find((j) => !TERMINAL.has(j.state));
    if (running) this.followJob(running);
    else if (jobs.length && first) this.jobStatus.show(jobs.sort((a, b) => b.id - a.id)[0]);
    if (!first && !running) await this.checkHead();
    clearTimeout(this.jobTimer);
    this.jobTimer = setTimeout(() => this.watchRunningJob(false).catch(() => {}), JOB_LOOK_MS);
  }

  // Someone else made a new head (applied, restored): offer to reload onto it; the edits on
  // screen are carried over then (DraftSync.attach rebases them).
  async checkHead() {
    const project = await get(`/projects/${this.store.project.id}`);
    const head = project.head_version_id;
    if (this.abort.signal.aborted || head === this.store.project.head_version_id) return;
    this.store.project.head_version_id = head;
    this.showBanner(`v${head} is the project's new head (made by someone else). Your edits are on v` +
      `${this.store.version?.id}; reload to carry them onto v${head}.`);
    const reload = document.createElement("button");
    reload.type = "button";
    reload.textContent = "Reload onto the new head";
    reload.addEventListener("click", async () => {
      await this.sync?.flush(); // the latest change is saved before the edit set is carried over
      this.reopen();
    }, { signal: this.abort.signal });
    this.root.querySelector("#banner").append(" ", reload);
  }

  // Lock editing while the job runs; when it ends, show the project's (new) head.
  async followJob(job) {
    this.setLocked(true, job);
    const done = await this.jobStatus.watch(job.id);
    this.setLocked(false);
    if (done.state === "succeeded") this.notify(done.message || `Job ${done.id} (${done.kind}) finished.`);
    else if (done.state === "cancelled") this.notify(`Job ${done.id} (${done.kind}) was cancelled.`, "warning");
    else this.notify(`Job ${done.id} failed: ${done.error ?? done.message ?? ""}`, "error");
    if (!this.abort.signal.aborted) this.reopen();
  }

  setLocked(locked, job = null) {
    this.store.locked = locked;
    this.root.dataset.locked = String(locked);
    this.showBanner(job ? `Editing is locked while job ${job.id} (${job.kind}) runs.` : null);
    this.triage?.update();
    this.refresh();
  }

  showBanner(text) {
    const banner = this.root.querySelector("#banner");
    const { readOnly, version, project } = this.store;
    const readOnlyText = `Viewing v${version?.id} read-only; the head is v${project.head_version_id}.`;
    const viewerText = "You are a viewer of this project: you can look, not change (ask an owner for the editor role).";
    const message = text ?? (readOnly ? readOnlyText : this.store.canWrite ? "" : viewerText);
    banner.textContent = message;
    banner.hidden = !message;
    if (readOnly && !text) {
      const back = document.createElement("a");
      back.href = `#/p/${project.id}`;
      back.textContent = " Back to the head";
      banner.append(back);
    }
  }

  // Show the project again (at its head when toHead), e.g. after a job or a restore.
  reopen(toHead = true) {
    const head = `#/p/${this.store.project.id}`;
    if (toHead && location.hash !== head) location.hash = head;
    else window.dispatchEvent(new CustomEvent("gsfm:reopen"));
  }

  // "Run reconstruction": save the edit set, apply it with remap, follow the job.
  async apply() {
    if (!this.editor.canEdit() || !this.sync) return;
    if (this.draft.cameras.size === 0 && this.draft.deletePairs.size === 0) {
      this.notify("Nothing to apply: move cameras or delete pairs first (no version is made).", "warning");
      return;
    }
    await this.sync.flush();
    if (this.sync.editId === null) await this.sync.save();
    const cuts = this.store.preview?.pairs_to_delete?.length ?? 0;
    const question = "The rule deletes no pair for these edits, so mapping again will most likely put " +
      "the cameras back where they were. Run the reconstruction anyway?";
    if (!cuts && !window.confirm(question)) return;
    try {
      const path = `/projects/${this.store.project.id}/edits/${this.sync.editId}/apply`;
      const note = this.root.querySelector("#apply-message")?.value.trim();
      const job = await post(path, note ? { remap: true, message: note } : { remap: true });
      this.notify(`Applying the edits: job ${job.id}.`);
      this.followJob(job);
    } catch (error) {
      this.notify(`Could not run the reconstruction: ${error.message}`, "error");
    }
  }
}
