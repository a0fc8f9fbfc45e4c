// The triage answer (GET .../versions/{vid}/suspects, design.md v1.1 "Triage") as the editor uses
// it: which suspects are raised, which run a camera belongs to, each run's state against the draft,
// the ghost cameras of the open proposals, and the runs dismissed in this tab for this version.

export const RAISE_AT = 0.5; // one threshold on every scene (design.md v1.1)
const SAME = 1e-9; // a draft pose within this of the proposal's is the proposal's

// The raised suspects, most likely misplaced first (capture order among equal scores).
export function raised(suspects, byId) {
  const seq = (s) => byId.get(s.image_id)?.seq ?? 0;
  return suspects.filter((s) => s.score >= RAISE_AT).sort((a, b) => b.score - a.score || seq(a) - seq(b));
}

export const runKey = (run) => run.image_ids.join("-");

// image id -> the run it belongs to (runs are disjoint).
export function runOf(runs) {
  const map = new Map();
  for (const run of runs) for (const id of run.image_ids) map.set(id, run);
  return map;
}

// "dismissed", "accepted" (the draft holds the proposal), "moved" (the draft moves the run's
// cameras elsewhere) or "open".
export function runState(run, draft, dismissed) {
  if (dismissed.has(runKey(run))) return "dismissed";
  const cameras = run.proposal?.cameras ?? [];
  if (cameras.length && cameras.every((c) => holds(draft.cameras.get(c.image_id), c))) return "accepted";
  return run.image_ids.some((id) => draft.cameras.has(id)) ? "moved" : "open";
}

function holds(edit, proposed) {
  return !!edit && Math.abs(edit.x - proposed.x) < SAME && Math.abs(edit.y - proposed.y) < SAME &&
    Math.abs(edit.yaw_deg - proposed.yaw_deg) < SAME;
}

// The proposed poses still to decide on, as ghost cameras; the hot run's (hovered) drawn larger.
export function ghostsOf(runs, draft, dismissed, hotRun) {
  const ghosts = [];
  for (const run of runs) {
    if (!run.proposal || ["dismissed", "accepted"].includes(runState(run, draft, dismissed))) continue;
    const key = runKey(run);
    for (const c of run.proposal.cameras) {
      ghosts.push({ id: c.image_id, x: c.x, y: c.y, yaw_deg: c.yaw_deg, run: key, hot: run === hotRun });
    }
  }
  return ghosts;
}

// Runs dismissed in this tab, per project version (sessionStorage: gone with the tab).
export class Dismissals {
  constructor(projectId, versionId) {
    this.key = `gsfm.dismissed.${projectId}.${versionId}`;
    this.keys = new Set(JSON.parse(sessionStorage.getItem(this.key) ?? "[]"));
  }

  has(key) { return this.keys.has(key); }
  get size() { return this.keys.size; }

  add(key) {
    this.keys.add(key);
    this.save();
  }

  clear() {
    this.keys.clear();
    this.save();
  }

  save() { sessionStorage.setItem(this.key, JSON.stringify([...this.keys])); }
}
