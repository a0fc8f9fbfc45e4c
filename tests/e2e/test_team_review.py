"""Team review in two browsers (ana and ben) against a real `guided-sfm serve` with a worker: a
comment pinned on a camera mentions ben, who sees the notification and the pin within one polling
period and replies; ana submits, ben approves, ana looks at it in 3D (points and frusta, checked on
pixels; WebGL through SwiftShader) and applies (the owner requires approval); both see the
activity and each other's presence; a comment holding markup is shown as text."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import PIL.Image
import pytest

from tests.e2e.conftest import ARTIFACTS, CHROMIUM, ConsoleLog, Server, free_port, stop
from tests.factories import PASSWORD, workspace_zip

pytestmark = pytest.mark.browser
POLL_S = 10  # the editor's polling period (frontend/js/team.js POLL_MS)
DOCS = Path(__file__).resolve().parents[2] / "docs" / "img"
MARKUP = "<b>bold?</b><script>window.pwned = 1</script>"


# WebGL without a GPU: SwiftShader, which headless Chromium only enables on request
GL_ARGS = ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
           "--disable-background-networking", "--disable-component-update", "--no-first-run"]
FRUSTUM_RGB, MOVED_RGB, BACKGROUND_RGB = (0x2B, 0x6C, 0xB0), (0xDD, 0x6B, 0x20), (0xFB, 0xFC, 0xFD)


@pytest.fixture(scope="module")
def gl_browser(playwright_driver) -> Iterator[object]:
    chromium = playwright_driver.chromium.launch(executable_path=str(CHROMIUM), args=GL_ARGS)
    yield chromium
    chromium.close()


@pytest.fixture(scope="module")
def team_server(tmp_path_factory, tiny_reconstruction, tiny_images) -> Iterator[tuple[Server, dict]]:
    """A real server (API and worker) with ana's project: the tiny sample imported, ben an editor,
    approval required before apply."""
    data_dir = tmp_path_factory.mktemp("gsfm-team")
    log = data_dir / "serve.log"
    port = free_port()
    command = [str(Path(sys.executable).with_name("guided-sfm")), "serve", "--data-dir", str(data_dir),
               "--port", str(port)]
    with log.open("w") as stderr:
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr, text=True,
                                   start_new_session=True)
    server = Server(f"http://127.0.0.1:{port}/", "ana", PASSWORD, data_dir, process, log)
    try:
        wait_healthy(server)
        tokens = {name: sign_up(server, name) for name in ("ana", "ben")}
        server.token = tokens["ana"]
        pid = make_team_project(server, workspace_zip(tiny_reconstruction, tiny_images / "images"))
        yield server, {"pid": pid}
    finally:
        server.client.close()
        stop(process)


def wait_healthy(server: Server, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            if server.client.get(server.api + "/health").status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.5)
    raise RuntimeError(f"the server did not answer within {timeout} s; see {server.log}")


def sign_up(server: Server, name: str) -> str:
    account = {"username": name, "password": PASSWORD}
    server.client.post(server.api + "/users", json=account).raise_for_status()
    answer = server.client.post(server.api + "/auth/token", data={"username": name, "password": PASSWORD})
    return answer.json()["access_token"]


def make_team_project(server: Server, zipped: bytes) -> int:
    pid = server.request("POST", "/projects", json={"name": "team"}).json()["id"]
    server.request("PUT", f"/projects/{pid}/members/ben", json={"role": "editor"}).raise_for_status()
    job = server.request("POST", f"/projects/{pid}/import", files={"file": ("ws.zip", zipped)}).json()
    assert server.wait_job(job["id"], timeout=300)["state"] == "succeeded"
    server.request("PATCH", f"/projects/{pid}", json={"require_approval": True}).raise_for_status()
    return pid


def open_as(browser, server: Server, name: str, pid: int) -> tuple[object, ConsoleLog]:
    context = browser.new_context(viewport={"width": 1440, "height": 900})
    page = context.new_page()
    page.set_default_timeout(30_000)
    console = ConsoleLog()
    page.on("console", console.on_console)
    page.on("pageerror", console.on_error)
    page.goto(server.url)
    form = page.locator("#sign-in-form")
    form.get_by_label("Username").fill(name)
    form.get_by_label("Password").fill(PASSWORD)
    form.get_by_role("button", name="Sign in").click()
    page.wait_for_selector("body[data-ready=projects]")
    page.evaluate("pid => { location.hash = `#/p/${pid}`; }", pid)
    page.wait_for_function("pid => (document.body.dataset.ready || '').startsWith(pid + '/')", arg=str(pid))
    return page, console


def shot(page, name: str) -> None:
    """A screenshot under test-artifacts/; with GSFM_DOCS_SHOTS=1 also into docs/img (the ones
    the README shows), so an ordinary run leaves the tree as it was."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=ARTIFACTS / f"{name}.png")
    if os.environ.get("GSFM_DOCS_SHOTS") == "1":
        DOCS.mkdir(parents=True, exist_ok=True)
        shutil.copy(ARTIFACTS / f"{name}.png", DOCS / f"{name}.png")


def pin_pixel(page, image_id: int | str) -> tuple[int, int, int]:
    """The canvas colour inside the camera's pin, where the scene says it drew it (beside its digit)."""
    return tuple(page.evaluate("""async (id) => {
        await new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done)));
        const c = document.querySelector('#scene');
        const spot = c.dataset.pinsAt.split(' ').find((p) => p.startsWith(id + ':'));
        const [x, y] = spot.split(':')[1].split(',').map(Number);
        return Array.from(c.getContext('2d').getImageData(x, y, 1, 1).data.slice(0, 3));
    }""", image_id))


def test_two_people_comment_review_and_apply(gl_browser, team_server):
    browser = gl_browser
    server, project = team_server
    pid = project["pid"]
    ana, ana_log = open_as(browser, server, "ana", pid)
    ben, ben_log = open_as(browser, server, "ben", pid)
    try:
        comment_and_reply(ana, ben)
        review_and_apply(ana, ben, server, pid)
        both_see_activity_and_presence(ana, ben)
    finally:
        for page, name in ((ana, "ana"), (ben, "ben")):
            page.screenshot(path=ARTIFACTS / f"team-{name}-last.png")
            page.context.close()
    assert not ana_log.unexpected() and not ben_log.unexpected(), (ana_log.errors, ben_log.errors)


def comment_and_reply(ana, ben) -> None:
    thumb = ana.locator("#strip .thumb").nth(2)
    camera = int(thumb.get_attribute("data-id"))
    thumb.click()
    ana.wait_for_selector(f"#thread[data-target='image:{camera}']")
    ana.fill("#comment-form textarea", f"@ben this camera is on the wrong wall {MARKUP}")
    ana.click("#comment-form button[type=submit]")
    posted = time.monotonic()
    ana.wait_for_selector("#thread li.comment >> text=wrong wall")
    assert f"{camera}:1" in ana.get_attribute("#scene", "data-pins").split(",")
    assert pin_pixel(ana, camera) == (0xD5, 0x3F, 0x8C)  # the pin's colour, drawn on the scene
    # ben: the notification, the pin and the strip's badge within one polling period
    ben.wait_for_selector("#inbox-button[data-unread='1']", timeout=(POLL_S + 3) * 1000)
    ben.wait_for_function("pin => (document.querySelector('#scene').dataset.pins || '').includes(pin)",
                          arg=f"{camera}:1", timeout=(POLL_S + 3) * 1000)
    assert time.monotonic() - posted <= POLL_S + 3
    assert ben.get_attribute(f"#strip .thumb[data-id='{camera}']", "data-comments") == "1"
    shot(ben, "team-ben-sees-the-pin")
    ben.click("#inbox-button")
    ben.wait_for_selector("#inbox li[data-kind=mention]")
    assert "ana mentioned you" in ben.inner_text("#inbox")
    ben.click("#inbox-button")
    ben.locator(f"#strip .thumb[data-id='{camera}']").click()
    body = ben.locator("#thread li.comment .body").first
    assert MARKUP in body.inner_text()  # shown as typed: text, not markup
    assert ben.locator("#thread li.comment .body b, #thread script").count() == 0
    assert ben.evaluate("window.pwned") is None
    ben.locator("#thread button[data-action=reply]").first.click()
    ben.fill("#comment-form textarea", "agreed, it belongs on the north wall")
    ben.click("#comment-form button[type=submit]")
    ben.wait_for_selector("#thread li.comment.reply >> text=north wall")
    ana.wait_for_selector("#thread li.comment.reply >> text=north wall", timeout=(POLL_S + 3) * 1000)
    pair_comment(ben)


def pair_comment(ben) -> None:
    """Two cameras selected: the thread is their pair's, and its pin sits at their midpoint."""
    first, second = (int(ben.locator("#strip .thumb").nth(i).get_attribute("data-id")) for i in (5, 6))
    ben.locator(f"#strip .thumb[data-id='{first}']").click()
    ben.locator(f"#strip .thumb[data-id='{second}']").click(modifiers=["Control"])
    key = "-".join(str(i) for i in sorted((first, second)))
    ben.wait_for_selector(f"#thread[data-target='pair:{key}']")
    ben.fill("#comment-form textarea", "these two do not overlap at all")
    ben.click("#comment-form button[type=submit]")
    ben.wait_for_function("pin => (document.querySelector('#scene').dataset.pins || '').includes(pin)",
                          arg=f"{key}:1")
    assert pin_pixel(ben, key) == (0xD5, 0x3F, 0x8C)
    ben.keyboard.press("Escape")


def review_and_apply(ana, ben, server: Server, pid: int) -> None:
    ana.locator("#scene").focus()
    ana.keyboard.press("Shift+ArrowRight")  # moves the selected camera: the edit set is saved
    ana.wait_for_selector("#cut-counter[data-state=ready]", timeout=60_000)
    ana.wait_for_selector("#submit-review:not([disabled])")
    ana.click("#submit-review")
    ana.wait_for_selector("#review-box[data-state=in_review]")
    assert ana.is_disabled("#approve")  # her own edit set
    eid = server.get(f"/projects/{pid}/edits")[0]["id"]
    gated = server.request("POST", f"/projects/{pid}/edits/{eid}/apply", json={"remap": True})
    assert gated.status_code == 409 and "in_review" in gated.json()["detail"]  # not approved yet
    mine = server.request("POST", f"/projects/{pid}/edits/{eid}/reviews", json={"verdict": "approve"})
    assert mine.status_code == 403  # ana cannot approve her own
    ben.wait_for_selector("#review-box[data-state=in_review]", timeout=(POLL_S + 3) * 1000)
    ben.fill("#review-comment", "checked against the north wall")
    ben.click("#approve")
    ben.wait_for_selector("#review-box[data-state=approved]")
    ana.wait_for_selector("#review-box[data-state=approved]", timeout=(POLL_S + 3) * 1000)
    assert "ben approved" in ana.inner_text("#review-list")
    shot(ana, "team-ana-approved")
    look_in_3d(ana)
    head = server.get(f"/projects/{pid}")["head_version_id"]
    ana.fill("#apply-message", "camera 3 back on the north wall")
    ana.once("dialog", lambda dialog: dialog.accept())  # the small move cuts no pair: the editor asks
    ana.click("#apply-button")
    ana.wait_for_function("h => !(document.body.dataset.ready || '').endsWith('/' + h)", arg=str(head),
                          timeout=300_000)
    new_head = server.get(f"/projects/{pid}")["head_version_id"]
    assert new_head != head
    version = next(v for v in server.get(f"/projects/{pid}/versions") if v["id"] == new_head)
    assert version["message"].startswith("camera 3 back on the north wall (edit set")


def both_see_activity_and_presence(ana, ben) -> None:
    for page in (ana, ben):
        page.evaluate("document.querySelector('#activity-panel').open = true")
        page.wait_for_selector("#activity-list li[data-action=apply]", timeout=(POLL_S + 3) * 1000)
        actions = page.eval_on_selector_all("#activity-list li", "all => all.map((i) => i.dataset.action)")
        assert {"comment", "edit_save", "submit", "review", "apply", "job_end"} <= set(actions), actions
        page.wait_for_function("() => document.querySelector('#presence').dataset.users === 'ana,ben'",
                               timeout=(POLL_S + 3) * 1000)
    shot(ana, "team-ana-activity")


def near(pixel, rgb, tolerance=40) -> bool:
    return sum(abs(a - b) for a, b in zip(pixel[:3], rgb, strict=True)) <= tolerance


def look_in_3d(ana) -> None:
    """The 3D view beside the top-down one: every registered camera's frustum, the points in their
    colours and the moved camera's frustum highlighted, on the canvas's pixels."""
    ana.click("#show-3d")
    ana.wait_for_function("() => Number(document.querySelector('#scene3d').dataset.frames || 0) > 0")
    assert int(ana.get_attribute("#scene3d", "data-frusta")) == 12
    assert int(ana.get_attribute("#scene3d", "data-points")) > 100
    moved = ana.get_attribute("#scene3d", "data-moved")
    assert moved and moved == ana.get_attribute("#scene", "data-moved")
    path = ARTIFACTS / "team-3d.png"
    ana.locator("#scene3d").screenshot(path=path)
    pixels = list(PIL.Image.open(path).convert("RGB").getdata())
    frustum = sum(near(p, FRUSTUM_RGB) for p in pixels)
    highlighted = sum(near(p, MOVED_RGB) for p in pixels)
    lines = (FRUSTUM_RGB, MOVED_RGB, BACKGROUND_RGB)
    coloured = sum(not any(near(p, rgb, 60) for rgb in lines) for p in pixels)  # the points' own colours
    print(f"3D view: {frustum} frustum, {highlighted} moved-frustum and {coloured} point pixels")
    assert frustum > 200 and highlighted > 20 and coloured > 100, (frustum, highlighted, coloured)
    shot(ana, "team-ana-3d")
    ana.click("#show-3d")
