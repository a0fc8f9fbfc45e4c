// Team review on the project page: comment threads (on the selected camera, else the project) with
// pins on the scene and badges on the strip, the edit set's review state and buttons, and who else
// is here (presence). Polls every POLL_MS. Comment bodies are shown as text, never as HTML.
import { get, post, request } from "./api.js";

export const POLL_MS = 10000;
const ROLES = ["viewer", "editor", "owner"];

export class TeamPanel {
  constructor(root, ctx, signal) {
    Object.assign(this, ctx, { root, signal });
    this.comments = [];
    this.editSet = null;
    this.el = (id) => root.querySelector(`#${id}`);
    this.el("comment-form").addEventListener("submit", (e) => { e.preventDefault(); this.postComment(); },
      { signal });
    this.el("thread").addEventListener("click", (e) => this.onThreadClick(e), { signal });
    this.el("submit-review").addEventListener("click", () => this.submit(), { signal });
    this.el("approve").addEventListener("click", () => this.review("approve"), { signal });
    this.el("request-changes").addEventListener("click", () => this.review("request_changes"), { signal });
    this.store.on("selection", () => this.renderThread());
    signal.addEventListener("abort", () => clearTimeout(this.timer));
  }

  get base() { return `/projects/${this.projectId}`; }
  get canEdit() { return ROLES.indexOf(this.store.project.role) >= 1; }

  // One round: presence, comments, the edit set's review; then again in POLL_MS.
  async poll() {
    clearTimeout(this.timer);
    try {
      await Promise.all([this.loadPresence(), this.loadComments(), this.loadReview()]);
    } catch (error) {
      this.root.dataset.pollError = error.message;
    }
    this.root.dataset.polls = String(Number(this.root.dataset.polls ?? 0) + 1);
    this.afterPoll?.();
    if (!this.signal.aborted) this.timer = setTimeout(() => this.poll(), POLL_MS);
  }

  // -- comments ----------------------------------------------------------------------------------

  async loadComments() {
    const comments = (await get(`${this.base}/comments`)) ?? [];
    if (this.signal.aborted) return; // the page closed meanwhile: its elements are the next page's
    this.comments = comments;
    const open = this.comments.filter((c) => !c.resolved);
    const count = this.el("unresolved-count");
    count.textContent = String(open.length);
    count.dataset.count = String(open.length);
    this.renderThread();
    this.renderPins(open);
    this.renderBadges(open);
  }

  // The thread shown: the one selected camera's, the two selected cameras' pair, else the project's.
  target() {
    const [first, ...more] = this.store.selection;
    if (first !== undefined && !more.length) return { kind: "image", id: first };
    if (more.length === 1) return { kind: "pair", image_ids: [first, more[0]].sort((a, b) => a - b) };
    return { kind: "project" };
  }

  onTarget(comment, target) {
    const key = (t) => `${t.kind}:${t.id ?? ""}:${(t.image_ids ?? []).join("-")}`;
    return key(comment.target) === key(target);
  }

  renderThread() {
    const target = this.target();
    const nameOf = (id) => this.store.byId.get(id)?.name ?? `image ${id}`;
    const name = target.kind === "image" ? nameOf(target.id)
      : target.kind === "pair" ? `the pair ${target.image_ids.map(nameOf).join(" – ")}` : "the project";
    this.el("thread-title").textContent = `Comments on ${name}`;
    const thread = this.comments.filter((c) => this.onTarget(c, target));
    const list = this.el("thread");
    list.dataset.target = target.kind === "image" ? `image:${target.id}`
      : target.kind === "pair" ? `pair:${target.image_ids.join("-")}` : "project";
    list.replaceChildren(...thread.map((c) => this.commentItem(c)));
    if (!thread.length) list.append(Object.assign(document.createElement("li"), { className: "hint",
      textContent: "No comments yet." }));
  }

  commentItem(comment) {
    const li = document.createElement("li");
    li.className = "comment";
    li.dataset.id = String(comment.id);
    li.dataset.resolved = String(comment.resolved);
    if (comment.parent_id) li.classList.add("reply");
    const head = document.createElement("div");
    head.className = "hint";
    head.textContent = `${comment.author ?? "someone"} · ${new Date(comment.created_at).toLocaleString()}` +
      (comment.resolved ? " · resolved" : "");
    const body = document.createElement("p");
    body.className = "body";
    body.textContent = comment.body; // plain text: markup in a body stays visible as typed
    const actions = document.createElement("div");
    actions.className = "row";
    actions.append(button("Reply", "reply", comment.id),
      button(comment.resolved ? "Reopen" : "Resolve", "resolve", comment.id));
    li.append(head, body, actions);
    return li;
  }

  async onThreadClick(e) {
    const action = e.target.closest("button[data-action]");
    if (!action) return;
    const id = Number(action.dataset.comment);
    const comment = this.comments.find((c) => c.id === id);
    if (action.dataset.action === "reply") {
      this.replyTo = id;
      const box = this.el("comment-form").elements.body;
      box.placeholder = `Reply to ${comment?.author ?? "the comment"}`;
      box.focus();
      return;
    }
    await this.guard(() => request("PATCH", `${this.base}/comments/${id}`,
      { json: { resolved: !comment?.resolved } }));
  }

  async postComment() {
    const form = this.el("comment-form");
    const text = form.elements.body.value;
    if (!text.trim()) return;
    const parent = this.comments.find((c) => c.id === this.replyTo);
    const body = { target: parent ? parent.target : this.target(), body: text };
    if (parent) body.parent_id = parent.id;
    const ok = await this.guard(() => post(`${this.base}/comments`, body));
    if (ok) {
      form.reset();
      this.replyTo = null;
      form.elements.body.placeholder = "Comment; @name mentions a member";
    }
  }

  // Run a change, report a refusal, reload the comments; true when it went through.
  async guard(change) {
    try {
      await change();
      await this.loadComments();
      return true;
    } catch (error) {
      this.notify(`Could not save the comment: ${error.message}`, "error");
      return false;
    }
  }

  // Pins at the cameras with open comments, and at the midpoint of pairs with some (drawn by the
  // scene's overlay hook); a pin's key is the image id, or "id1-id2" for a pair.
  renderPins(open) {
    const counts = new Map();
    for (const c of open) {
      const key = c.target.kind === "image" ? String(c.target.id)
        : c.target.kind === "pair" ? c.target.image_ids.join("-") : null;
      if (key) counts.set(key, (counts.get(key) ?? 0) + 1);
    }
    this.view.overlay = (ctx, t, px) => drawPins(ctx, t, px, this.view, counts);
    this.view.canvas.dataset.pins = [...counts].map(([key, n]) => `${key}:${n}`).join(",");
    this.view.requestDraw();
  }

  renderBadges(open) {
    for (const thumb of document.querySelectorAll("#strip .thumb")) {
      const n = open.filter((c) => c.target.kind === "image" && c.target.id === Number(thumb.dataset.id)).length;
      let badge = thumb.querySelector(".badge");
      if (!n) { badge?.remove(); delete thumb.dataset.comments; continue; }
      badge ??= thumb.appendChild(Object.assign(document.createElement("span"), { className: "badge" }));
      badge.textContent = String(n);
      thumb.dataset.comments = String(n);
    }
  }

  // -- review ------------------------------------------------------------------------------------

  // The edit set this page edits, else the newest one on the version on screen (a colleague's,
  // started after this page opened: the one a reviewer is asked about).
  async loadReview() {
    let id = this.editSetId();
    if (id === null && this.store.version) {
      const sets = ((await get(`${this.base}/edits`)) ?? []).filter((e) => e.base_version_id === this.store.version.id);
      id = sets.sort((a, b) => b.id - a.id)[0]?.id ?? null;
    }
    const editSet = id === null ? null : await get(`${this.base}/edits/${id}`);
    if (this.signal.aborted) return;
    this.editSet = editSet;
    this.renderReview();
  }

  renderReview() {
    const box = this.el("review-box");
    const set = this.editSet;
    const mine = set && [set.author, set.updated_by].includes(this.username);
    box.dataset.state = set?.review_state ?? "";
    this.el("review-state").textContent = set
      ? `Edit set ${set.id} (revision ${set.revision}, by ${set.author ?? "?"}): ${set.review_state.replace("_", " ")}`
      : "No edit set yet: move a camera to start one.";
    this.el("review-list").replaceChildren(...(set?.reviews ?? []).map((r) => {
      const li = document.createElement("li");
      li.textContent = `${r.reviewer} ${r.verdict === "approve" ? "approved" : "requested changes"} ` +
        `revision ${r.revision}${r.comment ? `: ${r.comment}` : ""}`;
      return li;
    }));
    const state = set?.review_state;
    this.el("submit-review").disabled = !set || !this.canEdit || !["draft", "changes_requested"].includes(state);
    for (const id of ["approve", "request-changes"]) {
      this.el(id).disabled = !set || !this.canEdit || state !== "in_review" || mine;
    }
  }

  async submit() {
    await this.flush();
    const id = this.editSetId();
    if (id === null) return;
    await this.act(() => post(`${this.base}/edits/${id}/submit`), "Submitted for review.");
  }

  async review(verdict) {
    const comment = this.el("review-comment").value;
    await this.act(() => post(`${this.base}/edits/${this.editSet.id}/reviews`, { verdict, comment }),
      verdict === "approve" ? "Approved." : "Changes requested.");
    this.el("review-comment").value = "";
  }

  async act(change, done) {
    try {
      await change();
      this.notify(done);
    } catch (error) {
      this.notify(`Review: ${error.message}`, "error");
    }
    await this.loadReview();
  }

  // -- presence ----------------------------------------------------------------------------------

  async loadPresence() {
    const body = { version_id: this.store.version?.id ?? null, edit_set_id: this.editSetId() ?? this.editSet?.id ?? null };
    const people = (await post(`${this.base}/presence`, body)) ?? [];
    if (this.signal.aborted) return;
    const line = this.el("presence");
    line.dataset.users = people.map((p) => p.username).join(",");
    line.textContent = "Here now: " + people.map((p) => (p.edit_set_id ? `${p.username} (edit set ${p.edit_set_id})`
      : p.username)).join(", ");
    const same = people.filter((p) => p.username !== this.username && p.edit_set_id !== null &&
      p.edit_set_id === body.edit_set_id);
    const warning = this.el("presence-warning");
    warning.hidden = !same.length;
    warning.textContent = same.length ? `${same.map((p) => p.username).join(", ")} ` +
      "is in this edit set too: coordinate before you both edit it." : "";
  }
}

function button(text, action, commentId) {
  const b = document.createElement("button");
  b.type = "button";
  b.textContent = text;
  b.dataset.action = action;
  b.dataset.comment = String(commentId);
  return b;
}

// Where each pin goes, in world coordinates: beside its camera, or at its pair's midpoint.
function pinSpots(view, counts) {
  const poses = new Map();
  for (const cam of view.cameras) {
    const pose = view.poseOf(cam);
    if (pose) poses.set(String(cam.id), pose);
  }
  const spots = [];
  for (const [key, n] of counts) {
    const ends = key.split("-").map((id) => poses.get(id));
    if (ends.some((p) => !p)) continue;
    const x = ends.reduce((sum, p) => sum + p.x, 0) / ends.length;
    const y = ends.reduce((sum, p) => sum + p.y, 0) / ends.length;
    spots.push({ key, n, x, y, beside: ends.length === 1 });
  }
  return spots;
}

// A speech-bubble pin with the number of open comments.
export function drawPins(ctx, t, px, view, counts) {
  ctx.save();
  ctx.font = `${10 * px}px system-ui, sans-serif`;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  const at = []; // where each pin was drawn (device pixels), for tests and tools
  for (const { key, n, x: wx, y: wy, beside } of pinSpots(view, counts)) {
    const [x, y] = t(wx, wy);
    const shift = beside ? 9 * px : 0;
    const [cx, cy, r] = [x + shift, y - shift, 7 * px];
    ctx.fillStyle = view.colours.pin ?? "#d53f8c";
    ctx.beginPath();
    ctx.arc(cx, cy, r, 0, 2 * Math.PI);
    ctx.fill();
    ctx.fillStyle = "#fff";
    ctx.fillText(String(n), cx, cy + 0.5 * px);
    at.push(`${key}:${Math.round(cx - 4 * px)},${Math.round(cy)}`);
  }
  ctx.restore();
  view.canvas.dataset.pinsAt = at.join(" ");
}
