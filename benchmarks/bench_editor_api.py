"""The editor's first draw on a real 1,000-camera scene payload from the API (issue 22).

A synthetic workspace (benchmarks/synthetic_workspace.py: pycolmap, no pixels, 1,000 cameras,
200,000 model points) is imported into a `guided-sfm serve` of its own through the REST import;
then: the scene payload the server sends (bytes plain and gzipped, points at the server's level
of detail and at ?max_points=20000, server seconds cold and cached), and in headless Chromium the
time from opening the project to the scene's first draw with every camera (the editor's own code:
fetch, gunzip, parse, set-up, fit, draw), cold and then warm (median of the reopenings).

    .venv/bin/python benchmarks/bench_editor_api.py [--workspace DIR] [--cameras 1000] [--opens 5]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import httpx
import PIL.Image
from playwright.sync_api import sync_playwright

sys.path.insert(0, str(Path(__file__).resolve().parent))
from synthetic_workspace import write_workspace  # noqa: E402

from guided_sfm.client import Client  # noqa: E402
from guided_sfm.core.workspace import Workspace  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
PASSWORD = "bench-password-1"
# Resolves at the first draw that shows every camera (data-cameras is the drawn count).
FIRST_DRAW = """cameras => new Promise((resolve) => {
  const canvas = document.getElementById("scene");
  const start = performance.now();
  new MutationObserver((_, observer) => {
    if (canvas.dataset.cameras === String(cameras)) {
      observer.disconnect();
      resolve(performance.now() - start);
    }
  }).observe(canvas, { attributes: true, attributeFilter: ["data-frame"] });
  location.hash = window.benchTarget;
})"""


def workspace_zip(root: Path) -> bytes:
    """database.db, sparse/0/ and a tiny JPEG per image name: what the import route takes."""
    buffer, tiny = io.BytesIO(), io.BytesIO()
    PIL.Image.new("RGB", (32, 24), (90, 90, 90)).save(tiny, "JPEG")
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        archive.write(root / "database.db", "database.db")
        for path in sorted((root / "sparse" / "0").iterdir()):
            archive.write(path, f"sparse/0/{path.name}")
        for name in Workspace(root).image_names().values():
            archive.writestr(f"images/{name}", tiny.getvalue())
    return buffer.getvalue()


def serve(data_dir: Path, port: int) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GUIDED_SFM_")}
    with open(data_dir.parent / "serve.log", "wb") as log:  # the child keeps its own handle
        process = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "serve", "--port", str(port),
                                    "--data-dir", str(data_dir)], env=env, stdout=subprocess.DEVNULL,
                                   stderr=log)
    for _ in range(600):
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/v1/health", timeout=2).status_code == 200:
                return process
        except httpx.HTTPError:
            time.sleep(0.5)
    process.kill()
    raise RuntimeError("serve did not answer")


def imported(url: str, root: Path) -> tuple[str, int, int]:
    """(token, project id, version id) of the workspace imported into a new project."""
    with Client(url) as api:
        api.sign_up("bench", PASSWORD)
        token = api.sign_in("bench", PASSWORD)
    with Client(url, token, timeout=600) as api:
        pid = api.create_project("synthetic 1,000")["id"]
        job = api.request("POST", f"/projects/{pid}/import",
                          files={"file": ("ws.zip", workspace_zip(root), "application/zip")})
        done = api.wait(job["id"])
    return token, pid, done["version_id"]


def save_payload(url: str, token: str, pid: int, vid: int, out: Path) -> None:
    """The scene (the server's level of detail, as the editor first asks) and every pair, as sent."""
    with Client(url, token, timeout=600) as api:
        scene = api.request("GET", f"/projects/{pid}/versions/{vid}/scene")
        pairs = api.request("GET", f"/projects/{pid}/versions/{vid}/pairs")
    out.write_text(json.dumps({"scene": scene, "pairs": pairs}))
    print(f"payload written: {len(scene['cameras'])} cameras, {len(pairs)} pairs")


def payload(url: str, token: str, pid: int, vid: int) -> list[str]:
    """The scene's bytes and server seconds at the default level and at every kept point."""
    lines = []
    headers = {"Authorization": f"Bearer {token}"}
    for query in ("", "?max_points=20000"):
        scene_url = f"{url}/api/v1/projects/{pid}/versions/{vid}/scene{query}"
        seconds = []
        for _ in range(2):  # cold (built and cached by the server), then cached
            start = time.perf_counter()
            response = httpx.get(scene_url, headers={**headers, "Accept-Encoding": "gzip"}, timeout=120)
            seconds.append(time.perf_counter() - start)
        wire = response.num_bytes_downloaded
        points = response.json()["points"]
        plain = len(response.content)
        lines.append(f"scene{query or ' (server level)'}: {len(points['xy'])} of {points['total']} points, "
                     f"{plain / 1e6:.2f} MB JSON, {wire / 1e6:.2f} MB gzipped; server {seconds[0]:.2f} s "
                     f"cold, {seconds[1]:.3f} s cached")
    return lines


def first_draws(url: str, pid: int, cameras: int, opens: int) -> list[float]:
    """ms from opening the project to the first draw of every camera, `opens` times."""
    times = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(url)
        form = page.locator("#sign-in-form")
        form.get_by_label("Username").fill("bench")
        form.get_by_label("Password").fill(PASSWORD)
        form.get_by_role("button", name="Sign in").click()
        page.wait_for_selector("body[data-ready=projects]")
        for _ in range(opens):
            page.evaluate("() => { location.hash = '#/'; }")
            page.wait_for_selector("body[data-ready=projects]")
            page.evaluate(f"() => {{ window.benchTarget = '#/p/{pid}'; }}")
            times.append(page.evaluate(FIRST_DRAW, cameras))
            page.wait_for_selector(f"body[data-ready^='{pid}/']")
        browser.close()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workspace", type=Path, default=None, help="reuse a synthetic workspace")
    parser.add_argument("--cameras", type=int, default=1000)
    parser.add_argument("--points", type=int, default=200_000)
    parser.add_argument("--opens", type=int, default=5)
    parser.add_argument("--save-payload", type=Path, default=None,
                        help="also write the scene and pair list the API sent, as JSON, for "
                             "bench_frontend.py --payload")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-editor-") as tmp:
        root = args.workspace or Path(tmp) / "ws"
        if args.workspace is None:
            print(write_workspace(root, args.cameras, args.points), file=sys.stderr)
        port = 20000 + os.getpid() % 20000
        (Path(tmp) / "data").mkdir()
        server = serve(Path(tmp) / "data", port)
        try:
            url = f"http://127.0.0.1:{port}"
            token, pid, vid = imported(url, root)
            print(f"{len(Workspace(root).image_names())} cameras, project {pid} version {vid}")
            print("\n".join(payload(url, token, pid, vid)))
            if args.save_payload:
                save_payload(url, token, pid, vid, args.save_payload)
            times = first_draws(url, pid, len(Workspace(root).image_names()), args.opens)
        finally:
            server.send_signal(signal.SIGTERM)
            server.wait(timeout=60)
    warm = statistics.median(times[1:]) if len(times) > 1 else times[0]
    print(f"editor first draw: {times[0]:.0f} ms cold, median {warm:.0f} ms reopened "
          f"(all: {', '.join(f'{t:.0f}' for t in times)}; target <= 2000)")
    print(f"load average {' '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
