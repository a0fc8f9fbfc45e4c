// Mouse on the scene: hover, click to select, drag the selection, drag empty space to pan,
// wheel to zoom (shift+wheel rotates the selection), and drop images from the strip. This is the
// scene's input: it is handed the scene view; it changes the draft through the editor.
import { DRAG_IMAGE } from "./state.js";

// `pointer` holds what the handlers share: the parts, and the gesture under way
// ({kind: "pan"|"drag"|"none", ...}) with a count of drags (each drag is one undo step).
export function bindPointer(canvas, { store, view, editor, selection }, signal) {
  const pointer = { canvas, store, view, editor, selection, gesture: null, drags: 0 };
  const listen = (type, handler, options = {}) =>
    canvas.addEventListener(type, handler, { signal, ...options });
  listen("pointerdown", (e) => press(pointer, e));
  listen("pointermove", (e) => move(pointer, e));
  listen("pointerup", (e) => { if (!toTool(pointer, "up", e)) end(pointer); });
  listen("dblclick", (e) => toTool(pointer, "dblclick", e));
  listen("pointercancel", () => end(pointer));
  listen("pointerleave", () => setHover(store, null));
  listen("wheel", (e) => wheel(pointer, e), { passive: false });
  listen("dragover", (e) => { if (e.dataTransfer.types.includes(DRAG_IMAGE)) e.preventDefault(); });
  listen("drop", (e) => drop(pointer, e));
}

// A drawing tool (store.tool, e.g. the path tool) takes the pointer while it is active.
function toTool({ store, view }, name, e) {
  if (!store.tool) return false;
  store.tool[name]?.(view.toWorld(e.clientX, e.clientY), e, view.worldPerPixel());
  return true;
}

function press(pointer, e) {
  if (e.button !== 0) return;
  pointer.canvas.focus();
  if (!toTool(pointer, "down", e)) pointer.gesture = startGesture(pointer, e);
  pointer.canvas.setPointerCapture(e.pointerId);
}

// A press on a camera selects (and, when editable, starts dragging the selection); a press on
// empty space starts a pan, which clears the selection if it ends without moving.
function startGesture(pointer, e) {
  const { store, view, editor, selection } = pointer;
  const hit = view.hitTest(e.clientX, e.clientY);
  const toggle = e.ctrlKey || e.metaKey;
  if (hit === null) {
    const last = view.toWorld(e.clientX, e.clientY);
    return { kind: "pan", last, moved: false, clear: !toggle && !e.shiftKey };
  }
  selectOnPress(hit, e, store, selection);
  const poses = store.editable && !toggle ? editor.selectedPoses() : [];
  pointer.drags += 1;
  return { kind: poses.length ? "drag" : "none", start: view.toWorld(e.clientX, e.clientY),
    poses, key: `drag${pointer.drags}` };
}

function move(pointer, e) {
  if (toTool(pointer, "move", e)) return;
  const { gesture, view } = pointer;
  if (!gesture) {
    setHover(pointer.store, view.hitTest(e.clientX, e.clientY));
    return;
  }
  const here = view.toWorld(e.clientX, e.clientY);
  if (gesture.kind === "pan") {
    view.panBy(here[0] - gesture.last[0], here[1] - gesture.last[1]);
    gesture.last = view.toWorld(e.clientX, e.clientY);
    gesture.moved = true;
  } else if (gesture.kind === "drag") {
    const [dx, dy] = [here[0] - gesture.start[0], here[1] - gesture.start[1]];
    pointer.editor.drag(gesture.poses, dx, dy, gesture.key);
  }
}

function end(pointer) {
  const { gesture } = pointer;
  if (gesture?.kind === "pan" && !gesture.moved && gesture.clear) pointer.selection.clear();
  pointer.gesture = null;
}

function setHover(store, id) {
  if (store.hovered === id) return;
  store.hovered = id;
  store.emit("hover");
}

function wheel({ store, view, editor }, e) {
  e.preventDefault();
  if (e.shiftKey && store.selection.size) {
    editor.move(0, 0, e.deltaY > 0 ? -2 : 2, "wheel-rotate");
  } else {
    view.zoomAt(e.clientX, e.clientY, Math.exp(-e.deltaY * 0.0015));
  }
}

// An image dropped from the strip is placed where it lands, and selected.
function drop({ view, editor, selection }, e) {
  const raw = e.dataTransfer.getData(DRAG_IMAGE);
  if (!raw) return;
  e.preventDefault();
  const id = Number(raw);
  const [x, y] = view.toWorld(e.clientX, e.clientY);
  editor.place([id], x, y);
  selection.set([id], id);
}

// A press on camera `hit`: a plain one on a split-off model selects its whole group (it moves as
// one piece), else it selects as a click does (shift extends, ctrl/cmd toggles); a press on the
// selection keeps it, to drag it.
function selectOnPress(hit, e, store, selection) {
  const toggle = e.ctrlKey || e.metaKey;
  const group = !toggle && !e.shiftKey && selection.groupOf(hit).length > 0;
  if (group && !store.selection.has(hit)) selection.selectGroup(hit);
  else if (!group && (toggle || e.shiftKey || !store.selection.has(hit))) {
    selection.click(hit, { shift: e.shiftKey, toggle });
  }
}
