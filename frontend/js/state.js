// The open project's state shared by the panels, with named change events. Panels never import
// each other: one panel changes the store and emits an event, the others listen (project.js wires
// the scene view to the events below).
//
//   "draft"      the draft edit set changed            (draft.js, via project.js)
//   "selection"  store.selection / store.anchor         (selection.js)
//   "hover"      store.hovered                          (pointer, strip, matching panel)
//   "preview"    store.preview / store.previewState     (sync.js)
//   "lines"      store.lines: match and cut lines       (preview panel) -> scene
//   "arrows"     store.arrows: comparison arrows        (versions panel) -> scene
//   "display"    store.showMatching / showFrusta / showOrder (controls) -> scene, preview
//   "view"       a command for the scene: {fit} | {zoom} | {pan: [x, y]} (share of the view)
//                | {show: [x, y]} (a world point, centred when off screen)
//   "role"       store.role changed (a refusal showed the role is now viewer)     (sync.js)
//   "triage"     store.triage: the version's suspects and runs arrived           (triage panel)
//   "ghosts"     store.ghosts: proposed poses drawn as ghost cameras             (triage panel) -> scene
//   "sketch"     store.sketch: the path being drawn                              (path tool) -> scene

// The drag-and-drop type of an image dragged from the strip onto the scene.
export const DRAG_IMAGE = "application/x-gsfm-image";

export function createStore() {
  const events = new EventTarget();
  return {
    project: null,
    version: null, // the version on screen
    frame: null, // the scene's ground frame {origin, x_axis, y_axis}
    readOnly: false, // an older version opened for viewing
    locked: false, // a job of this project is queued or running
    cameras: [], // [{id, name, seq, registered, x, y, yaw_deg, fov_deg, range, center}]
    byId: new Map(),
    images: [],
    points: new Float32Array(0),
    pairs: new Map(), // image id -> Map(partner id -> inliers)
    medianRange: 1, // of the cameras on screen; the unit of steps and thresholds
    selection: new Set(),
    anchor: null, // last clicked image, for shift-click ranges
    lastStepped: null, // last image reached with [ or ]
    hovered: null,
    showMatching: false,
    showFrusta: false,
    showOrder: true, // the capture-order line and camera numbers
    metresPerUnit: null, // from a known distance the user gave; the scale bar then shows metres
    preview: null, // the server's answer to GET .../edits/{id}/preview
    previewState: "none", // none | stale | ready
    lines: [], // [{a, b, kind: "match"|"cut"|"estimate", weight}]
    arrows: [], // [{id, from: [x, y], to: [x, y]}]
    triage: null, // GET .../suspects: {suspects, runs}
    ghosts: [], // [{id, x, y, yaw_deg, run, hot}]: proposed poses, not yet in the draft
    sketch: null, // {kind: "polyline", points, cursor} | {kind: "circle", centre, radius}
    tool: null, // a drawing tool that takes the scene's pointer and Enter/Escape while active
    on(name, handler) { events.addEventListener(name, (e) => handler(e.detail)); },
    emit(name, detail) { events.dispatchEvent(new CustomEvent(name, { detail })); },
    set(name, value) { this[name] = value; this.emit(name, value); },
    role: null, // the caller's role in the project: viewer | editor | owner
    // A viewer may read only (design.md v1.1); no role given: the server decides.
    get canWrite() { return this.role !== "viewer"; },
    get editable() { return this.canWrite && !this.readOnly && !this.locked && !!this.version; },
  };
}

// Scene cameras of the REST scene object, keyed by the image id.
export function camerasOf(scene) {
  return scene.cameras.map((c) => ({
    id: c.image_id, name: c.name, seq: c.seq, registered: c.registered,
    x: c.x ?? null, y: c.y ?? null, yaw_deg: c.yaw_deg ?? null,
    fov_deg: c.fov_deg ?? null, range: c.range ?? null, center: c.center ?? null,
    model: c.model ?? null, group: c.group_pose ?? null, // group: a split-off model's proposed pose
  }));
}

export function pointsOf(scene) {
  const xy = scene.points?.xy ?? [];
  const out = new Float32Array(xy.length * 2);
  xy.forEach(([x, y], i) => { out[2 * i] = x; out[2 * i + 1] = y; });
  return out;
}

// GET .../pairs rows as an adjacency map.
export function adjacency(rows) {
  const pairs = new Map();
  const link = (a, b, n) => {
    if (!pairs.has(a)) pairs.set(a, new Map());
    pairs.get(a).set(b, n);
  };
  for (const { image_id1: a, image_id2: b, num_inliers: n } of rows) {
    link(a, b, n);
    link(b, a, n);
  }
  return pairs;
}
