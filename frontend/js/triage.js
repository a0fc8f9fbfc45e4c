// The Suspects panel: the cameras the server thinks misplaced (score >= 0.5, most likely first,
// each with its reasons), the runs with their proposals (ghost cameras on the scene: accept puts
// them into the draft, adjust also selects them for the usual keys, dismiss hides them for this
// version in this tab) and the split-off models (select a group to move it as one piece).
// Hovering an entry lights its camera up in the scene and the strip (store "hover").
import { get } from "./api.js";
import { Dismissals, ghostsOf, raised, runKey, runOf, runState } from "./suspects.js";

export class TriagePanel {
  constructor(root, { store, draft, editor, selection, projectId, notify }, signal) {
    Object.assign(this, { root, store, draft, editor, selection, projectId, notify, signal });
    this.$ = (id) => root.querySelector(`#${id}`);
    this.runs = [];
    this.byRun = new Map();
    this.dismissed = new Dismissals(projectId, store.version?.id);
    const on = (el, type, handler) => el.addEventListener(type, handler, { signal });
    for (const list of [this.$("suspect-list"), this.$("run-list")]) {
      on(list, "pointerover", (e) => this.hover(e.target.closest("[data-hover]")));
      on(list, "pointerleave", () => this.hover(null));
      on(list, "focusin", (e) => this.hover(e.target.closest("[data-hover]")));
    }
    on(this.$("show-dismissed"), "click", () => { this.dismissed.clear(); this.render(); });
    store.on("draft", () => this.update());
    store.on("role", () => this.update());
    store.on("hover", () => this.markHovered());
    this.renderGroups();
  }

  async load() {
    const state = (s, text) => { this.root.dataset.state = s; this.$("triage-status").textContent = text; };
    if (!this.store.version) return state("none", "No version yet.");
    state("loading", "Looking for misplaced cameras…");
    try {
      const answer = await get(`/projects/${this.projectId}/versions/${this.store.version.id}/suspects`);
      if (this.signal.aborted) return undefined;
      this.store.set("triage", answer);
      this.runs = answer.runs ?? [];
      this.byRun = runOf(this.runs);
      this.render();
      return state("ready", this.summary());
    } catch (error) {
      return state("error", `Could not look for suspects: ${error.message}`);
    }
  }

  summary() {
    const n = this.raised.length;
    const proposals = this.runs.filter((r) => r.proposal).length;
    return n ? `${n} ${n === 1 ? "camera looks" : "cameras look"} misplaced (score ≥ 0.5); ${proposals} ` +
      `${proposals === 1 ? "proposal" : "proposals"}.` : "No camera looks misplaced (no score ≥ 0.5).";
  }

  render() {
    this.raised = raised(this.store.triage?.suspects ?? [], this.store.byId);
    const count = this.root.querySelector("#suspect-count");
    count.textContent = count.dataset.count = String(this.raised.length);
    this.$("suspect-list").replaceChildren(...this.raised.map((s) => this.suspectItem(s)));
    this.update();
  }

  // Run entries and ghosts follow the draft (accepting, undoing) and the dismissals.
  update() {
    const shown = this.runs.filter((r) => runState(r, this.draft, this.dismissed) !== "dismissed");
    this.$("run-list").replaceChildren(...shown.map((r) => this.runItem(r)));
    const hidden = this.dismissed.size;
    this.$("show-dismissed").hidden = !hidden;
    this.$("show-dismissed").textContent = `Show ${hidden} dismissed`;
    this.markHovered();
  }

  showGhosts() {
    const hot = this.byRun.get(this.store.hovered) ?? null;
    this.store.set("ghosts", ghostsOf(this.runs, this.draft, this.dismissed, hot));
  }

  name(id) {
    const cam = this.store.byId.get(id);
    return cam ? `${cam.name} (#${cam.seq + 1})` : `image ${id}`;
  }

  suspectItem(suspect) {
    const li = element("li", "suspect");
    Object.assign(li.dataset, { imageId: String(suspect.image_id), score: String(suspect.score),
      hover: String(suspect.image_id) });
    const pick = element("button", "link", this.name(suspect.image_id));
    pick.type = "button";
    pick.title = "Select it (its run if it has one); ctrl-click: this camera alone";
    pick.addEventListener("click", (e) => this.select(suspect.image_id, e.ctrlKey || e.metaKey),
      { signal: this.signal });
    const reasons = element("ul", "reasons");
    reasons.append(...suspect.reasons.map((r) => element("li", "", r)));
    li.append(pick, " ", element("span", "score", suspect.score.toFixed(2)), reasons);
    return li;
  }

  // Select the camera (alone) or its run, and bring the camera into view if it is off screen.
  select(id, alone) {
    const run = alone ? null : this.byRun.get(id);
    this.selection.set(run ? run.image_ids : [id], id);
    this.store.lastStepped = id;
    const pose = this.editor.poseOf(this.store.byId.get(id));
    if (pose) this.store.emit("view", { show: [pose.x, pose.y] });
  }

  runItem(run) {
    const state = runState(run, this.draft, this.dismissed);
    const li = element("li", "run");
    Object.assign(li.dataset, { run: runKey(run), state, hover: String(run.image_ids[0]) });
    const seqs = run.image_ids.map((id) => this.store.byId.get(id)?.seq ?? 0);
    const span = `#${Math.min(...seqs) + 1}–#${Math.max(...seqs) + 1}`;
    const title = `${span}: ${run.image_ids.length} ${run.image_ids.length === 1 ? "camera" : "cameras"}`;
    li.append(element("span", "run-title", title), element("p", "hint", run.reason));
    if (state !== "open") li.append(element("p", "run-state", STATES[state]));
    const row = element("div", "row");
    const buttons = run.proposal ? [["Accept", "accept", () => this.accept(run)],
      ["Adjust", "adjust", () => this.adjust(run)], ["Dismiss", "dismiss", () => this.dismiss(run)]]
      : [["Select", "select", () => this.select(run.image_ids[0], false)]];
    for (const [text, action, handler] of buttons) {
      const button = element("button", "", text);
      Object.assign(button, { type: "button", title: TITLES[action] });
      button.dataset.action = action;
      button.disabled = (action === "accept" && state === "accepted") ||
        (["accept", "adjust"].includes(action) && !this.store.editable);
      button.addEventListener("click", handler, { signal: this.signal });
      row.append(button);
    }
    li.append(row);
    return li;
  }

  // The proposal's poses into the draft: ordinary moves, one undo step.
  accept(run) {
    const poses = new Map(run.proposal.cameras.map((c) => [c.image_id, c]));
    if (this.editor.setPoses(poses)) this.notify(`Accepted the proposal for ${poses.size} cameras (undo: Ctrl+Z).`);
  }

  // At the proposed poses and selected, to move on with the arrow keys, q and r, or the mouse.
  adjust(run) {
    if (runState(run, this.draft, this.dismissed) !== "accepted" && !this.editor.setPoses(
      new Map(run.proposal.cameras.map((c) => [c.image_id, c])))) return;
    this.select(run.image_ids[0], false);
    document.querySelector("#scene")?.focus();
  }

  dismiss(run) {
    this.dismissed.add(runKey(run));
    this.update();
  }

  hover(entry) {
    const id = entry ? Number(entry.dataset.hover) : null;
    if (this.store.hovered === id) return;
    this.store.hovered = id;
    this.store.emit("hover");
  }

  markHovered() {
    for (const li of this.root.querySelectorAll("li.hovered")) li.classList.remove("hovered");
    const run = this.byRun.get(this.store.hovered);
    for (const li of this.root.querySelectorAll(`li[data-image-id="${this.store.hovered}"]`)) li.classList.add("hovered");
    if (run) this.root.querySelector(`li[data-run="${runKey(run)}"]`)?.classList.add("hovered");
    this.showGhosts();
  }

  // The split-off models (cameras with a group pose), each selectable as one piece.
  renderGroups() {
    const groups = new Map();
    for (const cam of this.store.cameras) {
      if (cam.group && cam.model !== null) groups.set(cam.model, [...(groups.get(cam.model) ?? []), cam.id]);
    }
    this.$("group-box").hidden = !groups.size;
    this.$("group-list").replaceChildren(...[...groups].map(([model, ids]) => {
      const li = element("li", "", `Model ${model}: ${ids.length} cameras `);
      li.dataset.model = String(model);
      const button = element("button", "", "Select group");
      Object.assign(button, { type: "button", title: "Select the whole model; then drag it, or arrows, q and r" });
      button.addEventListener("click", () => this.selection.selectGroup(ids[0]), { signal: this.signal });
      li.append(button);
      return li;
    }));
  }
}

const STATES = {
  accepted: "Accepted: the proposal is in the edit set.",
  moved: "Moved: the edit set places these cameras elsewhere (the ghosts show the proposal).",
};
const TITLES = {
  accept: "Put the proposed poses into the edit set (as moves; Ctrl+Z undoes)",
  adjust: "Put the proposed poses into the edit set and select the run, to move it on with the keys",
  dismiss: "Hide this proposal for this version (in this tab)",
  select: "Select the run's cameras",
};

function element(tag, className, text) {
  const el = document.createElement(tag);
  if (className) el.className = className;
  if (text !== undefined) el.textContent = text;
  return el;
}
