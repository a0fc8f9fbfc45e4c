// The Preview panel: match lines of the moved (and, with "show matching", the selected) cameras,
// the pairs the server's preview deletes in red, the counter and the warning when the match graph
// would split. Between a change and the server's answer (previewState "stale") it shows an
// instant estimate instead, dashed and marked "≈": the paper's triangle test on the moved cameras
// plus the manual deletions, nothing more. The server's rule ("default" unless the edit set says
// "paper") also judges the matches themselves, so the two counts may differ; the panel names both.
// The lines reach the scene through the store ("lines").
import { frustum, pairKey, splitKey, trianglesIntersect } from "./geometry.js";

const MAX_LINE_CAMERAS = 300; // beyond this many moved cameras only the cut lines are drawn

export class Preview {
  constructor(root, { store, draft, editor }) {
    Object.assign(this, { root, store, draft, editor });
    this.counter = root.querySelector("#cut-counter");
    this.warning = root.querySelector("#split-warning");
    this.details = root.querySelector("#preview-details");
  }

  // The instant estimate: pairs of a moved camera whose frustum triangles no longer meet (the
  // paper's triangle test), plus the manual deletions. Only the moved cameras' pairs are tested.
  estimate() {
    const { store, draft, editor } = this;
    const cuts = new Set(draft.deletePairs);
    for (const id of draft.cameras.keys()) {
      const a = editor.editPose(store.byId.get(id));
      if (!a) continue;
      const triangle = frustum(a);
      for (const partner of store.pairs.get(id)?.keys() ?? []) {
        const b = editor.editPose(store.byId.get(partner));
        if (b?.fov_deg && b.range && !trianglesIntersect(triangle, frustum(b))) cuts.add(pairKey(id, partner));
      }
    }
    return cuts;
  }

  serverCuts() {
    return new Set((this.store.preview?.pairs_to_delete ?? []).map(([a, b]) => pairKey(a, b)));
  }

  refresh() {
    const stale = this.store.previewState === "stale";
    const estimate = stale ? this.estimate() : null;
    this.store.set("lines", this.lines(stale ? estimate : this.serverCuts(), stale ? "estimate" : "cut"));
    this.renderCounter(estimate);
  }

  lines(cuts, cutKind) {
    const { store, draft } = this;
    const keys = new Map(); // pairKey -> inliers
    const addAll = (id) => {
      for (const [partner, n] of store.pairs.get(id) ?? []) keys.set(pairKey(id, partner), n);
    };
    if (draft.cameras.size <= MAX_LINE_CAMERAS) for (const id of draft.cameras.keys()) addAll(id);
    if (store.showMatching) for (const id of [...store.selection].slice(0, 50)) addAll(id);
    for (const key of cuts) if (!keys.has(key)) keys.set(key, 0);
    let max = 1;
    for (const n of keys.values()) if (n > max) max = n;
    return [...keys].map(([key, n]) => {
      const [a, b] = splitKey(key);
      const weight = store.showMatching ? 1 + 3 * Math.sqrt(n / max) : 1;
      const cut = cuts.has(key);
      return { a, b, kind: cut ? cutKind : "match", weight: cut ? Math.max(2, weight) : weight };
    });
  }

  // The server's count, or (estimate not null) the browser's estimate, each saying what it is.
  renderCounter(estimate) {
    const { preview, previewState } = this.store;
    const count = preview?.pairs_to_delete?.length ?? 0;
    const rule = `the server's "${this.draft.rule}" rule`;
    const c = this.counter;
    c.dataset.state = previewState;
    c.dataset.count = String(count);
    c.dataset.estimate = estimate ? String(estimate.size) : "";
    c.querySelector(".count").textContent = estimate ? `≈${estimate.size}` : String(count);
    c.querySelector(".note").textContent = estimate
      ? `instant estimate: the paper's triangle test in the browser; ${rule} answers after the save`
      : `pairs ${rule} would delete`;
    const split = preview && preview.components_after > preview.components_before;
    this.warning.hidden = !split;
    if (split) {
      this.warning.textContent = `Warning: the match graph would split from ${preview.components_before} into ` +
        `${preview.components_after} components; the model may break apart.`;
    }
    c.dataset.componentsBefore = String(preview?.components_before ?? "");
    c.dataset.componentsAfter = String(preview?.components_after ?? "");
    this.renderDetails(preview);
  }

  // The server's list, grouped by the moved camera each pair belongs to, each pair's reasons in
  // words. While a change is being saved the old list is not shown: only the estimate counts.
  renderDetails(preview) {
    const list = this.details;
    list.replaceChildren();
    list.dataset.state = this.store.previewState;
    if (!preview) return;
    if (this.store.previewState === "stale") {
      list.append(paragraph("Updating the server's preview…"));
      return;
    }
    list.append(paragraph(summaryText(preview)));
    const groups = this.groups(preview);
    for (const [id, rows] of groups) list.append(this.group(id, rows));
  }

  // camera id -> [[partner id, tests]], the camera being the pair's moved member (the earlier in
  // capture order when both moved or neither did, as for a manual deletion).
  groups(preview) {
    const reasons = new Map((preview.reasons ?? []).map((r) => [pairKey(...r.pair), r.tests]));
    const seq = (id) => this.store.byId.get(id)?.seq ?? id;
    const groups = new Map();
    for (const [a, b] of preview.pairs_to_delete.slice(0, MAX_ROWS)) {
      const [first, second] = seq(a) <= seq(b) ? [a, b] : [b, a];
      const owner = this.draft.cameras.has(second) && !this.draft.cameras.has(first) ? second : first;
      const partner = owner === a ? b : a;
      if (!groups.has(owner)) groups.set(owner, []);
      groups.get(owner).push([partner, reasons.get(pairKey(a, b)) ?? []]);
    }
    return [...groups].sort((x, y) => seq(x[0]) - seq(y[0]));
  }

  group(id, rows) {
    const name = (i) => { const c = this.store.byId.get(i); return c ? `${c.name} (#${c.seq + 1})` : `#${i}`; };
    const box = document.createElement("details");
    box.className = "cut-group";
    box.dataset.camera = String(id);
    const summary = document.createElement("summary");
    summary.textContent = `${name(id)}: ${rows.length} ${rows.length === 1 ? "pair" : "pairs"} cut`;
    const ul = document.createElement("ul");
    for (const [partner, tests] of rows) {
      const li = document.createElement("li");
      li.dataset.pair = pairKey(id, partner);
      li.textContent = `with ${name(partner)}: ${tests.map((t) => REASONS[t] ?? t).join("; ") || "cut"}`;
      ul.append(li);
    }
    box.append(summary, ul);
    return box;
  }
}

const MAX_ROWS = 500;

// Why a pair is cut, in words (the REST reasons' test names, docs/pruning-rule.md).
const REASONS = {
  frustum: "their view triangles no longer overlap",
  placement: "its matched points do not land where the placement puts them",
  rotation: "the placement turns the cameras too far apart for these matches",
  relative_pose: "the matches place the two cameras differently from the placement",
  separates: "it joins two groups the placement separates",
  check: "after the re-map it pulled a moved camera far from its placement",
  manual: "you deleted it",
};

function paragraph(text) {
  const p = document.createElement("p");
  p.textContent = text;
  return p;
}

function summaryText(preview) {
  const total = preview.pairs_to_delete.length;
  const byTest = Object.entries(preview.removed_by_test ?? {}).filter(([, n]) => n > 0);
  const tests = byTest.map(([t, n]) => `${n} ${REASONS[t] ?? t}`).join("; ");
  const sum = byTest.reduce((s, [, n]) => s + n, 0);
  const kept = (preview.kept_to_connect ?? []).length;
  return `${total} ${total === 1 ? "pair" : "pairs"} cut. Components: ${preview.components_before} before, ` +
    `${preview.components_after} after.` + (tests ? ` By test: ${tests}.` : "") +
    (sum > total ? " A pair can fail several tests, so these add up to more than the total." : "") +
    (kept ? ` Kept ${kept} pair(s) only the placement test cut, so no group of images is cut off.` : "");
}
