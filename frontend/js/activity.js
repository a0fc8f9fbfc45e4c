// The project's activity feed: newest first, "Older" pages back by id; an entry links to its
// version, selects its camera, or names its edit set.
import { get } from "./api.js";

const WORDS = {
  upload: "uploaded images", reconstruct: "started a reconstruction", import: "imported a workspace",
  edit_save: "saved", edit_delete: "deleted", submit: "submitted", review: "reviewed", apply: "applied",
  restore: "restored", publish: "published", member: "changed a member", comment: "commented on",
  settings: "changed the settings", job_end: "job ended:",
};

export class ActivityPanel {
  constructor(root, { projectId, selection }, signal) {
    Object.assign(this, { root, projectId, selection, signal });
    this.ticket = 0;
    this.list = root.querySelector("#activity-list");
    this.more = root.querySelector("#activity-more");
    this.more.addEventListener("click", () => this.load(this.next), { signal });
    this.list.addEventListener("click", (e) => {
      const camera = e.target.closest("button[data-camera]");
      if (camera) this.selection.click(Number(camera.dataset.camera), {});
    }, { signal });
  }

  // The newest page (replacing the list), or the page before `before` (appended). An answer that
  // arrives after a newer request's, or after the page closed, is dropped (the list is shared).
  async load(before = null) {
    const ticket = ++this.ticket;
    const query = before ? `?limit=30&before=${before}` : "?limit=30";
    const page = await get(`/projects/${this.projectId}/activity${query}`);
    if (ticket !== this.ticket || this.signal.aborted) return;
    const items = page.items.map((entry) => this.item(entry));
    if (before) this.list.append(...items);
    else this.list.replaceChildren(...items);
    this.next = page.next_before;
    this.more.hidden = page.next_before === null;
    this.list.dataset.count = String(this.list.children.length);
  }

  item(entry) {
    const li = document.createElement("li");
    li.dataset.action = entry.action;
    li.dataset.id = String(entry.id);
    const when = new Date(entry.at).toLocaleTimeString();
    const via = entry.token ? ` (via token ${entry.token})` : "";
    const detail = entry.action === "job_end" ? ` ${entry.detail.kind} ${entry.detail.state}`
      : entry.action === "edit_save" ? ` revision ${entry.detail.revision} of`
        : entry.action === "review" ? ` (${entry.detail.verdict.replace("_", " ")})` : "";
    li.append(`${when} ${entry.user ?? "someone"}${via} ${WORDS[entry.action] ?? entry.action}${detail} `);
    const link = this.link(entry.target);
    if (link) li.append(link);
    return li;
  }

  link(target) {
    if (target.kind === "version" && target.id) {
      const a = document.createElement("a");
      a.href = `#/p/${this.projectId}/v/${target.id}`;
      a.textContent = `version ${target.id}`;
      return a;
    }
    if (target.kind === "image" && target.id) {
      const b = document.createElement("button");
      b.type = "button";
      b.className = "link";
      b.dataset.camera = String(target.id);
      b.textContent = `camera ${target.id}`;
      return b;
    }
    if (target.kind === "edit_set") return `edit set ${target.id}`;
    if (target.kind === "pair") return `pair ${target.image_ids.join("-")}`;
    if (target.kind === "member") return target.username;
    return null;
  }
}
