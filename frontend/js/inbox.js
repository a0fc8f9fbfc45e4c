// Notifications in the top bar: a badge with the unread count (polled) and a list that marks
// what it shows as read.
import { get, post, session } from "./api.js";

const INBOX_POLL_MS = 10000; // as often as the team panel looks for comments

export class Inbox {
  constructor(button, panel) {
    Object.assign(this, { button, panel });
    this.count = button.querySelector(".badge");
    this.list = panel.querySelector("ol");
    button.addEventListener("click", () => this.toggle());
  }

  start() {
    if (this.timer || !session.token) return;
    this.button.hidden = false;
    this.poll();
  }

  stop() {
    clearTimeout(this.timer);
    this.timer = 0;
    this.button.hidden = true;
    this.panel.hidden = true;
  }

  async poll() {
    clearTimeout(this.timer);
    try {
      const unread = (await get("/notifications?unread=true")) ?? [];
      this.count.textContent = String(unread.length);
      this.button.dataset.unread = String(unread.length);
      this.button.setAttribute("aria-label", `Notifications: ${unread.length} unread`);
    } catch { /* signed out or the server is away: the next round tries again */ }
    this.timer = session.token ? setTimeout(() => this.poll(), INBOX_POLL_MS) : 0;
  }

  async toggle() {
    this.panel.hidden = !this.panel.hidden;
    this.button.setAttribute("aria-expanded", String(!this.panel.hidden));
    if (this.panel.hidden) return;
    const all = (await get("/notifications")) ?? [];
    this.list.replaceChildren(...all.slice(0, 30).map((n) => this.item(n)));
    if (!all.length) this.list.append(Object.assign(document.createElement("li"), { textContent: "Nothing yet." }));
    const unread = all.filter((n) => !n.read).map((n) => n.id);
    if (unread.length) await post("/notifications/read", { ids: unread });
    this.poll();
  }

  item(note) {
    const li = document.createElement("li");
    li.dataset.kind = note.kind;
    li.dataset.read = String(note.read);
    const a = document.createElement("a");
    a.href = `#/p/${note.project_id}`;
    a.textContent = note.text; // plain text, as typed
    a.addEventListener("click", () => { this.panel.hidden = true; });
    li.append(a);
    return li;
  }
}
