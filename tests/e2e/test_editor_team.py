"""The editor as a new team finds it (issue 18), in headless Chromium against the in-memory fake
of the REST contract: the capture order on the scene, Fit framing the cameras, role-aware and
safe controls, notices when a change is not kept. Fast: no server, no reconstruction."""

from __future__ import annotations

import json

import pytest

from tests.e2e.conftest import shot
from tests.e2e.fake_api import FakeApi
from tests.e2e.test_editor_offline import open_fake

pytestmark = pytest.mark.browser

ORDER_RGB = (0x71, 0x80, 0x96)  # --c-order


def view(page) -> tuple[float, float, float]:
    cx, cy, scale = map(float, page.get_attribute("#scene", "data-view").split(","))
    return cx, cy, scale


def pixel(page, x: float, y: float) -> tuple[int, int, int, int]:
    """The canvas's RGBA at world (x, y), after any pending frame is drawn."""
    return tuple(page.evaluate("""async ([x, y]) => {
        await new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done)));
        const c = document.querySelector('#scene');
        const [cx, cy, scale] = c.dataset.view.split(',').map(Number);
        const sx = Math.round(c.width / 2 + (x - cx) * scale);
        const sy = Math.round(c.height / 2 - (y - cy) * scale);
        return [...c.getContext('2d').getImageData(sx, sy, 1, 1).data];
    }""", [x, y]))


def test_capture_order_line_and_numbers_on_the_scene(page):
    """Cameras 1-5 stand in a row in capture order: a grey line joins each to the next (seen
    half-way between two of them) and each carries its number; the O key hides both."""
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#fit-view").click()
    assert page.get_attribute("#scene", "data-order-segments") == "4"  # 5 placed cameras
    labels = json.loads(page.get_attribute("#scene", "data-labels"))
    assert [text for text, _, _ in labels] == ["1", "2", "3", "4", "5"]
    for x in (0.5, 1.5, 3.5):
        *rgb, alpha = pixel(page, x, 0.0)
        assert alpha > 60 and max(abs(a - b) for a, b in zip(rgb, ORDER_RGB, strict=True)) < 40, (x, rgb)
    shot(page, "team-capture-order")
    page.locator("#scene").focus()
    page.keyboard.press("o")
    assert page.get_attribute("#show-order", "aria-pressed") == "false"
    assert pixel(page, 1.5, 0.0)[3] == 0  # the line is gone: the canvas is clear there
    assert page.get_attribute("#scene", "data-labels") == "[]"


@pytest.mark.parametrize("stray", [[], [[300.0, -250.0], [-400.0, 80.0], [120.0, 900.0]]],
                         ids=["sample-like", "far-stray-points"])
def test_fit_frames_the_cameras(page, stray):
    """The five cameras span 4 units; Fit makes that at least a third of the canvas's longer
    side, with or without stray points hundreds of units away."""
    fake = FakeApi(stray=[p for p in stray for _ in range(3)])  # more than 2% of the points
    open_fake(page, fake)
    page.locator("#scene").focus()
    page.keyboard.press("-")
    page.locator("#fit-view").click()
    page.wait_for_function("document.querySelector('#scene').dataset.view.split(',')[2] > 0")
    width, height = page.evaluate("(c => [c.width, c.height])(document.querySelector('#scene'))")
    cx, cy, scale = view(page)
    assert 4.0 * scale >= max(width, height) / 3, (scale, width, height)
    assert abs(cx - 2.0) * scale < width / 4  # centred on the cameras, not on the stray points
    shot(page, f"team-fit-{len(stray)}")


# Every control that changes the project; a viewer must find each disabled or hidden.
WRITE_CONTROLS = ["#apply-button", "#preview-button", "#undo", "#redo", "#flag-button", "#place-button",
                  "#reset-button", "#delete-matching", "#keep-matching", "#rule-select", "#fov-slider",
                  "#range-slider", "#upload-form button[type=submit]", "#upload-form input[type=file]",
                  "#reconstruct-button", "#version-list button[data-action=restore]", "#member-form button"]


def usable(page, selector: str) -> list[str]:
    """The elements of a selector a user could operate: visible and enabled."""
    return page.evaluate("""s => [...document.querySelectorAll(s)]
        .filter((e) => e.getClientRects().length && getComputedStyle(e).visibility !== 'hidden'
                       && !e.disabled && !e.closest('[hidden], details:not([open]) > :not(summary)'))
        .map((e) => e.id || e.textContent || e.tagName)""", selector)


def open_all_panels(page) -> None:
    page.evaluate("document.querySelectorAll('details').forEach((d) => { d.open = true; })")


def test_a_viewer_gets_no_control_it_cannot_use(page):
    fake = FakeApi(head=2, role="viewer")
    open_fake(page, fake)
    open_all_panels(page)
    page.locator("#strip .thumb[data-id='2']").click()  # a selection would enable the sliders
    page.wait_for_selector("#version-list li[data-version-id='1']", state="attached")
    for selector in WRITE_CONTROLS:
        assert usable(page, selector) == [], selector
    assert "viewer" in page.inner_text("#banner")
    box = page.locator("#scene").bounding_box()
    cx, cy, scale = view(page)
    start = (box["x"] + box["width"] / 2 + (1.0 - cx) * scale, box["y"] + box["height"] / 2 + cy * scale)
    page.mouse.move(*start)
    page.mouse.down()
    page.mouse.move(start[0] + 60, start[1] + 20, steps=4)
    page.mouse.up()
    assert page.get_attribute("#scene", "data-moved") == ""
    changes = [e for e in fake.log if e[0] in ("POST", "PUT", "DELETE") and "/projects/" in e[1]]
    assert [e for e in changes if not e[1].endswith("/presence")] == []  # a viewer reports presence (v1.1)
    shot(page, "team-viewer")


def test_a_drag_the_server_refuses_is_undone_on_screen(page, console):
    """The page thinks it may edit, the server says 403 (the role was lowered meanwhile): the
    camera goes back, a notice says the change was not kept, and the controls become a viewer's."""
    console.allow.append("403")
    fake = FakeApi(refuse_edits=True)
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='4']").click()
    page.locator("#scene").focus()
    page.keyboard.press("Shift+ArrowRight")
    assert "4" in page.get_attribute("#scene", "data-moved").split(",")
    page.wait_for_function("document.querySelector('#scene').dataset.moved === ''")
    notice = page.locator("#notice")
    assert "not kept" in notice.inner_text() and "viewer" in notice.inner_text()
    assert usable(page, "#apply-button") == [] and page.get_attribute("#scene", "data-editable") == "false"


def test_reconstruct_from_scratch_is_named_apart_and_confirmed(page, console):
    console.allow.append("409")
    fake = FakeApi(head=2)
    open_fake(page, fake)
    page.locator("#images-panel summary").click()
    scratch = page.locator("#reconstruct-button")
    assert scratch.inner_text() == "Reconstruct from scratch"
    assert page.inner_text("#apply-button") == "Run reconstruction"
    questions = []

    def answer(dialog, accept):
        questions.append(dialog.message)
        dialog.accept() if accept else dialog.dismiss()

    page.once("dialog", lambda d: answer(d, False))
    scratch.click()
    assert questions and "from scratch" in questions[0] and "v2" in questions[0]
    assert ("POST", "/api/v1/projects/1/reconstruct") not in fake.log  # dismissed: nothing queued
    page.once("dialog", lambda d: answer(d, True))
    scratch.click()
    page.wait_for_selector("#notice:has-text('Could not start the reconstruction')")
    assert ("POST", "/api/v1/projects/1/reconstruct") in fake.log and len(questions) == 2


def test_an_empty_apply_says_nothing_to_apply_and_sends_nothing(page):
    fake = FakeApi()
    open_fake(page, fake)
    page.get_by_role("button", name="Run reconstruction").click()
    page.wait_for_selector("#notice:has-text('Nothing to apply')")
    assert not [e for e in fake.log if e[0] == "POST" and "/edits" in e[1]]


def test_the_estimate_is_dropped_once_the_server_answers_and_the_cuts_are_grouped(page):
    """While the save is under way only the estimate counts (the old server list is not shown
    beside it); once the server answers, its count, its red lines and its list grouped by camera,
    each reason in words, with no estimate left."""
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='5']").click()
    page.locator("#scene").focus()
    for _ in range(3):
        page.keyboard.press("Shift+ArrowRight")  # 1.5 units: (3, 5) is cut by the server
    page.wait_for_selector("#cut-counter[data-state=ready][data-count='1']")
    stale = page.evaluate("""() => {
        document.querySelector('#scene').dispatchEvent(
            new KeyboardEvent('keydown', {key: 'ArrowRight', shiftKey: true, bubbles: true}));
        const c = document.querySelector('#cut-counter');
        const details = document.querySelector('#preview-details').innerText;
        return {shown: c.querySelector('.count').textContent, details};
    }""")
    assert stale["shown"].startswith("≈") and "Updating" in stale["details"]
    assert not any(ch.isdigit() for ch in stale["details"]), stale  # no old server figure beside the estimate
    page.wait_for_selector("#cut-counter[data-state=ready][data-count='2']")  # 2 units: (4, 5) too
    counter = page.locator("#cut-counter")
    assert counter.get_attribute("data-estimate") == "" and page.inner_text("#cut-counter .count") == "2"
    assert page.get_attribute("#scene", "data-red-lines") == "2"
    groups = page.locator("#preview-details .cut-group")
    assert [g.get_attribute("data-camera") for g in groups.all()] == ["5"]
    assert groups.first.locator("summary").inner_text() == "0005.jpg (#5): 2 pairs cut"
    groups.first.locator("summary").click()
    rows = groups.first.locator("li").all_inner_texts()
    assert len(rows) == 2 and all("do not land where the placement puts them" in r for r in rows)
    summary = page.inner_text("#preview-details p")
    assert "add up to more than the total" in summary and "placement" in summary
    shot(page, "team-cut-preview")


def test_reconstruct_from_scratch_is_disabled_without_images(page):
    fake = FakeApi()
    fake.cameras, fake.pairs = [], {}
    open_fake(page, fake)
    page.locator("#images-panel summary").click()
    assert page.locator("#reconstruct-button").is_disabled()


FAILED_JOB = {"id": 7, "project_id": 1, "kind": "apply", "state": "failed", "stage": "done", "progress": 0.4,
              "message": "", "error": "the worker stopped", "version_id": None,
              "created_at": "2026-01-01T00:00:00Z", "started_at": None, "finished_at": None}


def test_nothing_carries_over_from_one_project_to_the_next(page):
    """An error notice, the status bar's job and a typed username stay with their project."""
    fake = FakeApi(jobs=[FAILED_JOB])
    open_fake(page, fake)
    page.wait_for_selector("#status[data-job-id='7']")
    assert "failed" in page.inner_text("#job-text") and "done" not in page.inner_text("#job-text")
    page.locator("#strip .thumb[data-id='2']").click()
    page.locator("#scene").focus()
    page.keyboard.press("p")  # placing a placed camera: an info notice
    page.wait_for_selector("#notice:visible")
    page.wait_for_selector("#members-panel:not([hidden])")
    page.locator("#members-panel summary").click()
    page.locator("#member-form input[name=username]").fill("somebody")
    page.evaluate("location.hash = '#/'")
    page.wait_for_selector("body[data-ready=projects]")
    assert page.locator("#notice").is_hidden()
    assert page.inner_text("#job-text") == "No job." and page.get_attribute("#status", "data-job-id") is None
    card = page.inner_text("#project-list li[data-project-id='1']")
    assert "your role: owner" in card and "owner: fake-owner" in card
    fake.role = "viewer"  # an owner changed our role: the list shows it without a reload
    page.wait_for_selector("#project-list li:has-text('your role: viewer')", timeout=20_000)
    fake.jobs = []
    page.evaluate("location.hash = '#/p/1'")
    page.wait_for_selector("body[data-ready='1/1']")
    assert page.input_value("#member-form input[name=username]") == ""
    assert page.inner_text("#job-text") == "No job."
