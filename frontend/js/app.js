// Entry point: hash routes (#/, #/p/ID, #/p/ID/v/VID), sign-in, the project list, notices.
import { ApiError, del, get, post, session, setUnauthorizedHandler, signIn, signUp } from "./api.js";
import { Inbox } from "./inbox.js";
import { JobStatus } from "./jobs.js";
import { ProjectPage } from "./project.js";

const $ = (id) => document.getElementById(id);
const jobStatus = new JobStatus($("status"));
const inbox = new Inbox($("inbox-button"), $("inbox"));
let page = null;

function notify(text, kind = "info") {
  const box = $("notice");
  box.textContent = text;
  box.dataset.kind = kind;
  box.hidden = false;
  clearTimeout(notify.timer);
  if (kind === "info") notify.timer = setTimeout(() => { box.hidden = true; }, 8000);
}

function show(viewId) {
  for (const id of ["view-auth", "view-projects", "view-project"]) $(id).hidden = id !== viewId;
  $("user-name").textContent = session.username ? `Signed in as ${session.username}` : "";
  $("sign-out").hidden = !session.token;
}

function crumbs(items) {
  $("crumbs").replaceChildren(...items.map(([text, href]) => {
    const a = document.createElement(href ? "a" : "span");
    a.textContent = text;
    if (href) a.href = href;
    return a;
  }));
}

const LIST_REFRESH_MS = 15000; // the project list looks again for projects you were added to

// Nothing of the page left behind carries over to another project: notices, the job, typed
// fields, the upload's report. Reopening the same project (after an upload, a job, a restore)
// keeps them: they report what just happened there.
function forgetPage(nextProjectId = null) {
  const same = nextProjectId !== null && page?.store.project?.id === nextProjectId;
  page?.close();
  page = null;
  clearTimeout(showProjects.timer);
  if (same) return;
  $("notice").hidden = true;
  jobStatus.clear();
  for (const form of document.querySelectorAll("#view-project form")) form.reset();
  $("upload-status").textContent = "";
  $("upload-progress").hidden = true;
}

async function route() {
  const match = session.token ? /^#\/p\/(\d+)(?:\/v\/(\d+))?/.exec(location.hash) : null;
  forgetPage(match ? Number(match[1]) : null);
  if (session.token) inbox.start();
  else inbox.stop();
  if (!session.token) {
    crumbs([]);
    show("view-auth");
    return;
  }
  if (!match) return showProjects();
  show("view-project");
  const current = new ProjectPage($("view-project"), { jobStatus, notify, username: session.username });
  page = current;
  try {
    await current.open(Number(match[1]), match[2] ? Number(match[2]) : null);
    const { project, version, readOnly } = current.store;
    crumbs([["Projects", "#/"], [project.name, `#/p/${project.id}`],
      [version ? `v${version.id}${readOnly ? " (read-only)" : ""}` : "no version yet"]]);
    document.body.dataset.ready = `${project.id}/${version?.id ?? ""}`;
  } catch (error) {
    if (page === current) notify(`Could not open the project: ${error.message}`, "error");
  }
}

async function showProjects(first = true) {
  if (first) {
    crumbs([["Projects"]]);
    show("view-projects");
  }
  const list = $("project-list");
  try {
    const projects = (await get("/projects")) ?? [];
    if (page || !/^#?\/?$/.test(location.hash)) return; // left the list meanwhile
    list.replaceChildren(...projects.map(projectCard));
    if (!projects.length) list.textContent = "No projects yet: create one below.";
    document.body.dataset.ready = "projects";
  } catch (error) {
    if (first) notify(`Could not list the projects: ${error.message}`, "error");
  }
  clearTimeout(showProjects.timer);
  showProjects.timer = setTimeout(() => showProjects(false), LIST_REFRESH_MS);
}

function projectCard(p) {
  const li = document.createElement("li");
  li.dataset.projectId = String(p.id);
  const a = document.createElement("a");
  a.href = `#/p/${p.id}`;
  a.textContent = p.name;
  const meta = document.createElement("span");
  meta.className = "hint";
  const head = p.head_version_id ? `head v${p.head_version_id}` : "no version yet";
  const who = [p.role ? `your role: ${p.role}` : "", p.owner ? `owner: ${p.owner}` : ""].filter(Boolean);
  meta.textContent = [p.description, head, ...who].filter(Boolean).join(" · ");
  li.append(a, meta);
  if (p.role === "owner") {
    const remove = document.createElement("button");
    remove.type = "button";
    remove.className = "danger";
    remove.textContent = "Delete";
    remove.title = `Delete project "${p.name}" with all its images and versions`;
    remove.addEventListener("click", () => deleteProject(p));
    li.append(remove);
  }
  return li;
}

async function deleteProject(p) {
  const question = `Delete project "${p.name}" with all its images, versions and edits? This cannot be undone.`;
  if (!window.confirm(question)) return;
  try {
    await del(`/projects/${p.id}`);
    notify(`Deleted project "${p.name}".`);
  } catch (error) {
    notify(`Could not delete project "${p.name}": ${error.message}`, "error");
  }
  showProjects(false);
}

$("sign-in-form").addEventListener("submit", async (e) => {
  e.preventDefault();
  const data = new FormData(e.target);
  try {
    await signIn(String(data.get("username")), String(data.get("password")));
    e.target.reset();
    route();
  } catch (error) {
    notify(`Sign-in failed: ${error.message}`, "error");
  }
});

$("sign-up").addEventListener("click", async () => {
  const form = $("sign-in-form");
  if (!form.reportValidity()) return;
  const data = new FormData(form);
  const [username, password] = [String(data.get("username")), String(data.get("password"))];
  try {
    await signUp(username, password);
    await signIn(username, password);
    form.reset();
    notify(`Welcome, ${username}.`);
    route();
  } catch (error) {
    notify(`Sign-up failed: ${error.message}`, "error");
  }
});

$("sign-out").addEventListener("click", () => {
  session.clear();
  location.hash = "#/";
  route();
});

$("new-project-form").addEventListener("submit", async (e) => {
  e.preventDefault();
  const data = new FormData(e.target);
  const body = { name: String(data.get("name")) };
  if (data.get("description")) body.description = String(data.get("description"));
  try {
    const project = await post("/projects", body);
    e.target.reset();
    location.hash = `#/p/${project.id}`;
  } catch (error) {
    notify(`Could not create the project: ${error.message}`, "error");
  }
});

setUnauthorizedHandler((error) => {
  if (!(error instanceof ApiError) || !session.token) return;
  session.clear();
  notify("Your session ended; please sign in again.", "warning");
  route();
});

window.addEventListener("hashchange", route);
window.addEventListener("gsfm:reopen", route);
route();
