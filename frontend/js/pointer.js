// Mouse on the scene: hover, click to select, drag the selection, drag empty space to pan,
// wheel to zoom (shift+wheel rotates the selection), and drop images from the strip. This is the
// scene's input: it is handed the scene view; it changes the draft through the editor.
import { DRAG_IMAGE } from "./state.js";

export function bindPointer(canvas, { store, view, editor, selection }, signal) {
  let gesture = null; // {kind: "pan"|"drag", x, y, moved, start}
  let drags = 0;

  // A drawing tool (store.tool, e.g. the path tool) takes the pointer while it is active.
  const toTool = (name, e) => {
    if (!store.tool) return false;
    store.tool[name]?.(view.toWorld(e.clientX, e.clientY), e, view.worldPerPixel());
    return true;
  };

  canvas.addEventListener("pointerdown", (e) => {
    if (e.button !== 0) return;
    canvas.focus();
    if (toTool("down", e)) {
      canvas.setPointerCapture(e.pointerId);
      return;
    }
    const hit = view.hitTest(e.clientX, e.clientY);
    const toggle = e.ctrlKey || e.metaKey;
    if (hit !== null) {
      selectOnPress(hit, e, store, selection);
      const poses = store.editable && !toggle ? editor.selectedPoses() : [];
      gesture = { kind: poses.length ? "drag" : "none", start: view.toWorld(e.clientX, e.clientY),
        poses, key: `drag${(drags += 1)}` };
    } else {
      const last = view.toWorld(e.clientX, e.clientY);
      gesture = { kind: "pan", last, moved: false, clear: !toggle && !e.shiftKey };
    }
    canvas.setPointerCapture(e.pointerId);
  }, { signal });

  canvas.addEventListener("pointermove", (e) => {
    if (toTool("move", e)) return undefined;
    if (!gesture) return hover(e);
    const here = view.toWorld(e.clientX, e.clientY);
    if (gesture.kind === "pan") {
      view.panBy(here[0] - gesture.last[0], here[1] - gesture.last[1]);
      gesture.last = view.toWorld(e.clientX, e.clientY);
      gesture.moved = true;
    } else if (gesture.kind === "drag") {
      const [dx, dy] = [here[0] - gesture.start[0], here[1] - gesture.start[1]];
      editor.drag(gesture.poses, dx, dy, gesture.key);
    }
  }, { signal });

  const end = () => {
    if (gesture?.kind === "pan" && !gesture.moved && gesture.clear) selection.clear();
    gesture = null;
  };
  canvas.addEventListener("pointerup", (e) => { if (!toTool("up", e)) end(); }, { signal });
  canvas.addEventListener("dblclick", (e) => toTool("dblclick", e), { signal });
  canvas.addEventListener("pointercancel", end, { signal });
  canvas.addEventListener("pointerleave", () => setHover(null), { signal });

  function hover(e) { setHover(view.hitTest(e.clientX, e.clientY)); }
  function setHover(id) {
    if (store.hovered === id) return;
    store.hovered = id;
    store.emit("hover");
  }

  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    if (e.shiftKey && store.selection.size) {
      editor.move(0, 0, e.deltaY > 0 ? -2 : 2, "wheel-rotate");
    } else {
      view.zoomAt(e.clientX, e.clientY, Math.exp(-e.deltaY * 0.0015));
    }
  }, { signal, passive: false });

  canvas.addEventListener("dragover", (e) => {
    if (e.dataTransfer.types.includes(DRAG_IMAGE)) e.preventDefault();
  }, { signal });
  canvas.addEventListener("drop", (e) => {
    const raw = e.dataTransfer.getData(DRAG_IMAGE);
    if (!raw) return;
    e.preventDefault();
    const id = Number(raw);
    const [x, y] = view.toWorld(e.clientX, e.clientY);
    editor.place([id], x, y);
    selection.set([id], id);
  }, { signal });
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
