"""Scene panel benchmark in headless Chromium: a synthetic 1,000-camera, 200,000-point scene.

Serves frontend/ and a generated page on a local port (no API server), then reports the time to
first render (JSON parse of the scene, scene set-up, fit, first draw, until the pixels exist) and
the frame time while a selection of 50 cameras moves (editor move, live-preview estimate over the
match pairs, redraw). Every timed frame ends with a 1-pixel readback, which makes Chromium raster
the canvas before the clock stops. Targets (issue 4): first render < 1 s, median frame < 16 ms.

    .venv/bin/python benchmarks/bench_frontend.py [--cameras 1000] [--points 200000] [--frames 120]
        [--payload FILE]

--payload takes a real scene and pair list as the API sent them (bench_editor_api.py
--save-payload FILE) in place of the synthetic scene.

The first draw on a real 1,000-camera payload from the API (import, scene at the server's level of
detail, the whole editor opening the project) is benchmarks/bench_editor_api.py.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import sys
import threading
from pathlib import Path

from playwright.sync_api import sync_playwright

FRONTEND = Path(__file__).resolve().parents[1] / "frontend"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]

PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><link rel="icon" href="data:,">
<link rel="stylesheet" href="/css/app.css">
<style>body{margin:0} #scene{width:1200px;height:800px;display:block}</style></head>
<body>
<canvas id="scene"></canvas>
<div id="preview-panel"><div id="cut-counter"><span class="count"></span><span class="note"></span></div>
<p id="split-warning"></p><div id="preview-details"></div></div>
<script type="module">
import { SceneView } from "/js/scene.js";
import { Draft } from "/js/draft.js";
import { Editor } from "/js/editor.js";
import { Preview } from "/js/preview.js";
import { Selection } from "/js/selection.js";
import { adjacency, camerasOf, createStore, pointsOf } from "/js/state.js";

const CONFIG = __CONFIG__;

function rng(seed) {  // mulberry32
  return () => {
    seed |= 0; seed = (seed + 0x6D2B79F5) | 0;
    let t = Math.imul(seed ^ (seed >>> 15), 1 | seed);
    t = (t + Math.imul(t ^ (t >>> 7), 61 | t)) ^ t;
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// A walk through a 60 x 40 room: cameras along a loop, points on the walls and scattered inside.
function sceneJson() {
  const r = rng(7);
  const cameras = [];
  for (let i = 0; i < CONFIG.cameras; i++) {
    const t = (i / CONFIG.cameras) * 2 * Math.PI;
    const x = 30 + 22 * Math.cos(t) + r() - 0.5;
    const y = 20 + 13 * Math.sin(t) + r() - 0.5;
    const registered = i % 97 !== 0;  // a few unregistered images, as in real projects
    cameras.push({ image_id: i + 1, name: `${String(i).padStart(4, "0")}.jpg`, seq: i, registered,
      model: registered ? 0 : null, x: registered ? x : null, y: registered ? y : null,
      yaw_deg: registered ? ((t * 180) / Math.PI + 90) % 360 - 180 : null,
      fov_deg: 60, range: 4, center: registered ? [x, y, 1.5] : null,
      qvec: registered ? [1, 0, 0, 0] : null });
  }
  const xy = [];
  for (let i = 0; i < CONFIG.points; i++) {
    const side = r();
    if (side < 0.7) {
      const u = r() * 200;
      const p = u < 60 ? [u, 0] : u < 100 ? [60, u - 60] : u < 160 ? [160 - u, 40] : [0, 200 - u];
      xy.push([+(p[0] + (r() - 0.5) * 0.6).toFixed(4), +(p[1] + (r() - 0.5) * 0.6).toFixed(4)]);
    } else {
      xy.push([+(r() * 60).toFixed(4), +(r() * 40).toFixed(4)]);
    }
  }
  const frame = { origin: [0, 0, 0], x_axis: [1, 0, 0], y_axis: [0, 1, 0], up: [0, 0, 1] };
  const models = [{ index: 0, num_images: CONFIG.cameras }];
  return JSON.stringify({ frame, cameras, points: { xy }, models });
}

function pairsOf(n) {  // each camera matched to its 10 capture-order successors
  const rows = [];
  for (let i = 1; i <= n; i++) for (let k = 1; k <= 10 && i + k <= n; k++) {
    rows.push({ image_id1: i, image_id2: i + k, num_inliers: 20 + ((i * 7 + k * 13) % 200) });
  }
  return rows;
}

const flush = (view) => view.ctx.getImageData(0, 0, 1, 1);

window.runBench = async () => {
  const text = CONFIG.sceneText ?? sceneJson();
  const pairRows = CONFIG.pairRows ?? pairsOf(CONFIG.cameras);
  await new Promise(requestAnimationFrame);
  const t0 = performance.now();
  const scene = JSON.parse(text);
  const store = createStore();
  store.cameras = camerasOf(scene);
  store.byId = new Map(store.cameras.map((c) => [c.id, c]));
  store.points = pointsOf(scene);
  store.pairs = adjacency(pairRows);
  store.version = { id: 1 };
  store.project = { id: 1 };
  store.previewState = "stale"; // no server here: the live estimate is what is drawn
  const view = new SceneView(document.getElementById("scene"));
  const draft = new Draft();
  const selection = new Selection(store);
  const editor = new Editor(store, draft, selection, () => {}, () => [view.view.cx, view.view.cy]);
  view.setScene(store.cameras, store.points);
  view.poseOf = (cam) => editor.poseOf(cam);
  view.fit();
  view.draw();
  flush(view);
  const firstRender = performance.now() - t0;

  const preview = new Preview(document.getElementById("preview-panel"), { store, draft, editor });
  store.on("lines", (lines) => view.setLines(lines));
  draft.onChange = () => {
    view.moved = new Set(draft.cameras.keys());
    preview.refresh();
  };
  selection.set(store.cameras.slice(100, 150).map((c) => c.id));
  view.selected = store.selection;
  view.showFrusta = CONFIG.frusta;
  const frames = [];
  const edits = [];
  for (let i = 0; i < CONFIG.frames; i++) {
    const start = performance.now();
    if (i % 2) editor.move(0, 0, 1.5, "rotate");
    else editor.move(editor.step, editor.step / 2, 0, "move1");
    edits.push(performance.now() - start);
    view.draw();
    flush(view);
    frames.push(performance.now() - start);
    await new Promise(requestAnimationFrame);
  }
  return { firstRender, frames, edits, moved: draft.cameras.size, lines: view.lines.length,
    redLines: Number(view.canvas.dataset.redLines), size: [view.canvas.width, view.canvas.height] };
};
window.benchReady = true;
</script></body></html>
"""


class Handler(http.server.SimpleHTTPRequestHandler):
    page = b""

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        if self.path.split("?")[0] in ("/", "/bench.html"):
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(self.page)))
            self.end_headers()
            self.wfile.write(self.page)
            return
        super().do_GET()

    def log_message(self, *args: object) -> None:
        pass


def serve(config: dict) -> http.server.ThreadingHTTPServer:
    Handler.page = PAGE.replace("__CONFIG__", json.dumps(config)).encode()
    handler = functools.partial(Handler, directory=str(FRONTEND))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def run(config: dict) -> dict:
    server = serve(config)
    errors: list[str] = []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1280, "height": 900}, device_scale_factor=1)
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"http://127.0.0.1:{server.server_address[1]}/bench.html")
            page.wait_for_function("window.benchReady === true")
            result = page.evaluate("window.runBench()")
            browser.close()
    finally:
        server.shutdown()
    if errors:
        raise RuntimeError(f"console errors in the benchmark page: {errors}")
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cameras", type=int, default=1000)
    parser.add_argument("--points", type=int, default=200_000)
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--frusta", action="store_true", help="draw the frustum triangles too")
    parser.add_argument("--payload", type=Path, default=None,
                        help="a real scene and pair list from the API (bench_editor_api.py "
                             "--save-payload) instead of the synthetic scene")
    args = parser.parse_args()
    config = {"cameras": args.cameras, "points": args.points, "frames": args.frames, "frusta": args.frusta}
    if args.payload:
        real = json.loads(args.payload.read_text())
        config.update(sceneText=json.dumps(real["scene"]), pairRows=real["pairs"])
        args.cameras, args.points = len(real["scene"]["cameras"]), len(real["scene"]["points"]["xy"])
    result = run(config)
    frames = result["frames"][5:]  # the first frames include JIT warm-up
    median = percentile(frames, 0.5)
    print(f"scene: {args.cameras} cameras, {args.points} points, canvas {result['size'][0]}x"
          f"{result['size'][1]}, frusta {'on' if args.frusta else 'off'}")
    print(f"time to first render: {result['firstRender']:.0f} ms (target < 1000)")
    print(f"frame while moving 50 cameras: median {median:.1f} ms, p95 {percentile(frames, 0.95):.1f} ms, "
          f"max {max(frames):.1f} ms over {len(frames)} frames (target median < 16)")
    print(f"  of which the edit and live-preview estimate: median "
          f"{percentile(result['edits'][5:], 0.5):.1f} ms; the rest is drawing and raster")
    print(f"moved {result['moved']} cameras; {result['lines']} match lines drawn, "
          f"{result['redLines']} of them red (estimated cuts)")
    ok = result["firstRender"] < 1000 and median < 16
    print("targets met" if ok else "targets NOT met")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
