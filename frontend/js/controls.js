// Toolbar buttons, the selection panel (FoV and range sliders) and the page's keyboard shortcuts.
// The scene is not its to touch: display toggles and view commands go out as store events.

const FORM_FIELDS = "input, textarea, select, [contenteditable]";
const PAN_SHARE = 0.1; // Alt+arrow pans by this share of the view's width

// page: { flush() (save and preview now), apply() (apply the edit set and map again) }.
// `controls` holds what the handlers share: the parts, `$` (an element of root by id), the two
// frustum sliders, `view` (a view command out as a store event) and the toolbar's actions by id.
export function bindControls(root, parts, signal) {
  const $ = (id) => root.querySelector(`#${id}`);
  const controls = { ...parts, root, $, fov: $("fov-slider"), range: $("range-slider"),
    view: (command) => parts.store.emit("view", command) };
  scaleRangeSlider(controls);
  controls.actions = toolbarActions(controls);
  for (const [id, handler] of Object.entries(controls.actions)) {
    $(id).addEventListener("click", handler, { signal });
  }
  bindInputs(controls, signal);
  document.addEventListener("keydown", (e) => onKey(controls, e), { signal });
  return { refresh: () => refresh(controls) };
}

// The range slider spans a tenth to four times the scene's median range.
function scaleRangeSlider({ range, editor }) {
  range.min = String(editor.medianRange * 0.1);
  range.max = String(editor.medianRange * 4);
  range.step = String(editor.medianRange / 200);
}

function toolbarActions(controls) {
  const { store, editor, selection, page, view } = controls;
  const toggle = (key) => {
    store[key] = !store[key];
    store.emit("display");
  };
  return {
    undo: () => editor.undo(),
    redo: () => editor.redo(),
    "select-all": () => selection.all(),
    "show-matching": () => toggle("showMatching"),
    "show-frusta": () => toggle("showFrusta"),
    "show-order": () => toggle("showOrder"),
    "fit-view": () => view({ fit: true }),
    "preview-button": () => showPreview(controls),
    "apply-button": () => page.apply(),
    "flag-button": () => editor.toggleFlag(),
    "place-button": () => editor.placeSelectionAtCentre(),
    "reset-button": () => editor.resetSelected(),
    "scale-button": () => setScale(controls),
  };
}

// The frustum sliders and the rule of the draft.
function bindInputs({ $, fov, range, editor, draft }, signal) {
  fov.addEventListener("input", () => editor.setFrustum({ fov_deg: Number(fov.value) }, "fov"), { signal });
  range.addEventListener("input", () => editor.setFrustum({ range: Number(range.value) }, "range"), { signal });
  $("rule-select").addEventListener("change", (e) => {
    if (!editor.canEdit()) return;
    draft.change((d) => { d.rule = e.target.value; });
  }, { signal });
}

// Save the draft, then say what the server's preview would delete and open its panel.
async function showPreview({ $, page, store, draft, notify }) {
  $("preview-panel").open = true;
  await page.flush();
  const n = store.preview?.pairs_to_delete?.length ?? 0;
  notify(draft.empty ? "Nothing to preview: move cameras or delete pairs first."
    : `The rule would delete ${n} ${n === 1 ? "pair" : "pairs"} (listed in Preview); they are deleted ` +
      "when you Run reconstruction.");
  $("cut-counter").scrollIntoView({ block: "nearest" });
  $("preview-panel").querySelector("summary").focus();
}

// A known distance between two selected cameras sets metres per model unit (kept per project in
// this browser); an empty answer goes back to the model's units.
function setScale({ store, editor, notify }) {
  const poses = editor.selectedPoses();
  if (poses.length !== 2) return notify("Select exactly two placed cameras whose distance you know.");
  const units = Math.hypot(poses[0].x - poses[1].x, poses[0].y - poses[1].y);
  const answer = window.prompt(`Distance between ${poses[0].name} and ${poses[1].name} in metres ` +
    `(${units.toPrecision(3)} units apart in the scene); leave empty to show units again:`);
  if (answer === null) return undefined;
  const metres = Number(answer.replace(",", "."));
  if (answer.trim() && !(metres > 0 && units > 0)) return notify(`"${answer}" is not a distance in metres.`);
  store.metresPerUnit = answer.trim() ? metres / units : null;
  const key = `gsfm.scale.${store.project.id}`;
  if (store.metresPerUnit) localStorage.setItem(key, String(store.metresPerUnit));
  else localStorage.removeItem(key);
  store.emit("display");
  return undefined;
}

// The page's shortcuts, outside form fields: Alt+arrows pan, the editor's keys, then the view's.
function onKey(controls, e) {
  if (e.target.closest?.(FORM_FIELDS)) return;
  const handled = e.altKey ? panKey(controls, e) : controls.editor.handleKey(e) || viewKey(controls, e);
  if (handled) e.preventDefault();
}

// Alt+arrows pan the view by a tenth of its size.
function panKey({ view }, e) {
  const arrows = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
  if (!arrows[e.key]) return false;
  view({ pan: [-arrows[e.key][0] * PAN_SHARE, -arrows[e.key][1] * PAN_SHARE] });
  return true;
}

function viewKey({ $, actions, view }, e) {
  if (e.ctrlKey || e.metaKey) return false;
  const keys = {
    m: actions["show-matching"], t: actions["show-frusta"], o: actions["show-order"],
    d: actions["preview-button"],
    0: () => view({ fit: true }),
    "+": () => view({ zoom: 1.25 }), "=": () => view({ zoom: 1.25 }), "-": () => view({ zoom: 0.8 }),
    "?": () => {
      $("keys-panel").open = true;
      $("keys-panel").scrollIntoView({ block: "nearest" });
      $("keys-panel").querySelector("summary").focus();
    },
  };
  const handler = keys[e.key.toLowerCase()];
  if (!handler) return false;
  handler();
  return true;
}

const EDIT_BUTTONS = ["undo", "redo", "preview-button", "apply-button", "flag-button", "place-button",
  "reset-button", "delete-matching", "keep-matching", "rule-select"];

function refresh(controls) {
  const { $, root, store, draft, editor } = controls;
  const poses = editor.selectedPoses();
  const n = store.selection.size;
  $("selection-summary").textContent = n
    ? `${n} selected, ${poses.length} placed${n > poses.length ? ` (${n - poses.length} to place)` : ""}.`
    : "Nothing selected.";
  refreshButtons(controls, poses);
  if (poses.length) showFrustum(controls, poses[0]);
  for (const [id, key] of [["show-matching", "showMatching"], ["show-frusta", "showFrusta"],
    ["show-order", "showOrder"]]) $(id).setAttribute("aria-pressed", String(store[key]));
  root.dataset.selectionCount = String(n);
  warnFarPlacements($("placement-warning"), store, draft, editor);
}

// What may be pressed: editing needs an editable draft, the sliders a placed selection.
function refreshButtons({ $, store, draft, fov, range }, poses) {
  const editable = store.editable;
  for (const id of EDIT_BUTTONS) $(id).disabled = !editable;
  $("undo").disabled ||= !draft.undoStack.length;
  $("redo").disabled ||= !draft.redoStack.length;
  $("reconstruct-button").disabled = store.locked || !store.canWrite || !store.cameras.length;
  fov.disabled = range.disabled = !editable || !poses.length;
  $("rule-select").value = draft.rule;
}

// The sliders and their labels show the first selected camera's frustum.
function showFrustum({ $, fov, range, editor }, pose) {
  fov.value = String(pose.fov_deg ?? 60);
  range.value = String(pose.range ?? editor.medianRange);
  $("fov-value").textContent = `${Math.round(pose.fov_deg ?? 0)}°`;
  $("range-value").textContent = `${(pose.range ?? 0).toPrecision(3)}`;
}

const FAR_RANGES = 4; // a placement this many median ranges from every matched camera is suspect

// A placement far from every camera it matches (behind the facade, 60 units away) is most likely
// a slip: say so beside the selection, naming the cameras and the distance.
function warnFarPlacements(box, store, draft, editor) {
  const far = [];
  for (const id of draft.cameras.keys()) {
    const cam = store.byId.get(id);
    const pose = cam && editor.editPose(cam);
    const partners = [...(store.pairs.get(id)?.keys() ?? [])].map((p) => store.byId.get(p)).filter(Boolean)
      .map((c) => editor.editPose(c)).filter(Boolean);
    if (!pose || !partners.length) continue;
    const nearest = Math.min(...partners.map((p) => Math.hypot(p.x - pose.x, p.y - pose.y)));
    if (nearest > FAR_RANGES * editor.medianRange) far.push(`${cam.name} (${nearest.toPrecision(3)} units)`);
  }
  box.hidden = !far.length;
  box.textContent = far.length ? `Check the placement: ${far.join(", ")} from the nearest camera it ` +
    `matches, over ${FAR_RANGES}× the typical range (${editor.medianRange.toPrecision(3)}).` : "";
}
