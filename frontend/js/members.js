// Members of a project (owners only): list, add or change a role, remove.
import { del, get, put } from "./api.js";

const ROLES = ["viewer", "editor", "owner"];

export class MembersPanel {
  constructor(root, { projectId, notify }, signal) {
    Object.assign(this, { root, projectId, notify });
    this.list = root.querySelector("#member-list");
    this.form = root.querySelector("#member-form");
    this.form.addEventListener("submit", (e) => {
      e.preventDefault();
      const data = new FormData(this.form);
      this.setRole(String(data.get("username")).trim(), String(data.get("role")));
    }, { signal });
    this.list.addEventListener("change", (e) => {
      const select = e.target.closest("select[data-username]");
      if (select) this.setRole(select.dataset.username, select.value);
    }, { signal });
    this.list.addEventListener("click", (e) => {
      const button = e.target.closest("button[data-username]");
      if (button) this.remove(button.dataset.username);
    }, { signal });
  }

  get base() { return `/projects/${this.projectId}/members`; }

  async load() {
    const members = (await get(this.base)) ?? [];
    this.list.replaceChildren(...members.map((m) => this.row(m)));
    return members;
  }

  row({ username, role }) {
    const li = document.createElement("li");
    const name = document.createElement("span");
    name.textContent = username;
    const select = document.createElement("select");
    select.dataset.username = username;
    select.setAttribute("aria-label", `Role of ${username}`);
    for (const r of ROLES) select.append(new Option(r, r, false, r === role));
    const remove = document.createElement("button");
    remove.type = "button";
    remove.textContent = "Remove";
    remove.dataset.username = username;
    remove.setAttribute("aria-label", `Remove ${username}`);
    li.append(name, select, remove);
    return li;
  }

  async setRole(username, role) {
    if (!username) return;
    try {
      await put(`${this.base}/${encodeURIComponent(username)}`, { role });
      this.notify(`${username} is now ${role}.`);
      this.form.reset();
    } catch (error) {
      this.notify(`Could not set the role of ${username}: ${error.message}`, "error");
    }
    await this.load();
  }

  async remove(username) {
    try {
      await del(`${this.base}/${encodeURIComponent(username)}`);
      this.notify(`${username} removed.`);
    } catch (error) {
      this.notify(`Could not remove ${username}: ${error.message}`, "error");
    }
    await this.load();
  }
}
