"""The editor as a new team finds it (issue 18), in headless Chromium against the in-memory fake
of the REST contract: the capture order on the scene, Fit framing the cameras, role-aware and
safe controls, notices when a change is not kept. Fast: no server, no reconstruction."""

from __future__ import annotations

import json

import pytest

from tests.e2e.conftest import shot
from tests.e2e.fake_api import ORIGIN, FakeApi
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
                  "#reconstruct-button", "#version-list button[data-action=restore]", "#member-form button",
                  "#match-list input", "#delete-images"]


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
    assert [e for e in changes if not e[1].endswith("/presence")] == []  # a viewer may post presence
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


def stale_edit(base: int) -> dict:
    """An edit set saved on an older version: camera 2 moved, camera 9 (gone since) placed, the
    pair (1, 2) and a pair the head no longer matches deleted."""
    return {"id": 1, "revision": 3, "base_version_id": base, "updated_by": "fake-user",
            "updated_at": "2026-01-01T00:00:00Z", "rule": "default", "flags": [],
            "cameras": [{"image_id": 2, "x": 1.2, "y": 0.3, "yaw_deg": 90.0, "fov_deg": 60.0, "range": 2.0},
                        {"image_id": 9, "x": 0.0, "y": 1.0, "yaw_deg": 0.0, "fov_deg": 60.0, "range": 2.0}],
            "delete_pairs": [[1, 2], [1, 5]]}


def test_a_stale_edit_set_is_rebased_onto_the_head_with_a_report(page):
    """The head moved on (v2) while edits sat on v1: opening the head carries them over and says
    what was carried and what could not be; the move is on screen, not lost."""
    fake = FakeApi(head=2)
    fake.edit = stale_edit(1)
    open_fake(page, fake)
    page.wait_for_selector("#notice:has-text('carried onto the head v2')")
    text = page.inner_text("#notice")
    assert "1 camera(s), 1 deletion(s)" in text and "Not carried" in text, text
    assert "camera #9" in text and "delete pair 0001.jpg–0005.jpg" in text, text
    assert fake.edit["base_version_id"] == 2 and fake.edit["revision"] == 4
    assert ("POST", "/api/v1/projects/1/edits/1/rebase") in fake.log
    assert page.get_attribute("#scene", "data-moved") == "2"
    shot(page, "team-rebase")


def open_second_tab(page, fake: FakeApi):
    """A second page of the same browser (signed in already, sharing the fake server)."""
    other = page.context.new_page()
    fake.install(other)
    other.goto(f"{ORIGIN}/#/p/1")
    other.wait_for_selector(f"body[data-ready='1/{fake.head}']")
    return other


def move(page, image_id: int, key: str = "Shift+ArrowUp") -> None:
    page.locator(f"#strip .thumb[data-id='{image_id}']").click()
    page.locator("#scene").focus()
    page.keyboard.press(key)
    page.wait_for_selector("#cut-counter[data-state=ready]")


def test_two_tabs_never_drop_a_change_silently(page, console):
    """Tab B opens before tab A saves anything; both then move different cameras, each from its
    own stale copy. Every move ends up in the one edit set, and each merge is announced."""
    console.allow.append("409")  # tab A's stale save, expected
    fake = FakeApi()
    open_fake(page, fake)
    other = open_second_tab(page, fake)
    move(page, 2)  # tab A creates the edit set
    move(other, 4)  # tab B knew of none: it joins A's instead of starting a second one
    other.wait_for_selector("#notice:has-text('merged into them')")
    assert sorted(c["image_id"] for c in fake.edit["cameras"]) == [2, 4]
    move(page, 3)  # tab A's copy is stale (B saved revision 2): a 409, merged and saved again
    page.wait_for_selector("#notice:has-text('merged onto theirs')")
    assert sorted(c["image_id"] for c in fake.edit["cameras"]) == [2, 3, 4]
    assert sorted(page.get_attribute("#scene", "data-moved").split(",")) == ["2", "3", "4"]
    other.close()


def test_a_new_head_made_elsewhere_is_noticed_and_the_edits_follow_it(page):
    """Someone else's apply makes v2 the head while this page edits v1: the page notices within
    its polling period, offers to reload, and reloading carries the edits onto v2."""
    fake = FakeApi(head=1)
    open_fake(page, fake)
    move(page, 2)
    fake.head = 2  # made elsewhere
    page.wait_for_selector("#banner:has-text('new head')", timeout=25_000)
    page.get_by_role("button", name="Reload onto the new head").click()
    page.wait_for_selector("body[data-ready='1/2']")
    page.wait_for_selector("#notice:has-text('carried onto the head v2')")
    assert fake.edit["base_version_id"] == 2 and page.get_attribute("#scene", "data-moved") == "2"


def test_delete_image_export_a_version_and_delete_the_project_from_the_ui(page, console):
    """The Images panel deletes the selected images (the server keeps one a version uses and
    says why), each version row exports COLMAP or PLY, the project list deletes a project."""
    console.allow.append("409")
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='2']").click()
    page.locator("#strip .thumb[data-id='6']").click(modifiers=["Control"])
    page.locator("#images-panel summary").click()
    page.once("dialog", lambda d: d.accept())
    page.get_by_role("button", name="Delete selected images").click()
    page.wait_for_selector("#upload-status:has-text('0006.jpg deleted')")
    status = page.inner_text("#upload-status")
    assert "0002.jpg kept: image 0002.jpg is used by version(s) v1" in status, status
    assert ("DELETE", "/api/v1/projects/1/images/6") in fake.log
    assert 6 not in [c["image_id"] for c in fake.cameras]

    page.locator("#versions-panel summary").click()
    row = page.locator("#version-list li[data-version-id='1']")
    with page.expect_download() as download:
        row.get_by_role("button", name="Export COLMAP").click()
    assert download.value.suggested_filename == "fake-v1.zip"
    assert ("GET", "/api/v1/projects/1/versions/1/export") in fake.log

    page.evaluate("location.hash = '#/'")
    page.wait_for_selector("body[data-ready=projects]")
    questions = []
    page.once("dialog", lambda d: (questions.append(d.message), d.accept()))
    page.locator("#project-list li[data-project-id='1']").get_by_role("button", name="Delete").click()
    page.wait_for_selector("#project-list:has-text('No projects yet')")
    assert ("DELETE", "/api/v1/projects/1") in fake.log and "cannot be undone" in questions[0]


def test_an_upload_goes_in_batches_and_one_bad_file_costs_only_itself(page, console, tmp_path):
    """Ten files, one bad: the first batch of eight is refused whole (all or nothing), so it is
    sent again file by file; nine images are stored and the bad one is named, without a path."""
    console.allow.append("422")
    fake = FakeApi()
    open_fake(page, fake)
    names = [f"{i:02d}.jpg" for i in range(9)] + ["bad-03.jpg"]
    names[3], names[9] = names[9], names[3]
    for name in names:
        (tmp_path / name).write_bytes(b"\xff\xd8 not really a jpeg")
    page.locator("#images-panel summary").click()
    page.set_input_files("#upload-form input[type=file]", [str(tmp_path / n) for n in names])
    page.get_by_role("button", name="Upload", exact=True).click()
    page.wait_for_selector("#images-panel[data-uploaded='9'][data-refused='1']")
    status = page.inner_text("#upload-status")
    assert status.startswith("Uploaded 9 images.") and "Not uploaded: bad-03.jpg: not a readable" in status
    assert "/" not in status and page.locator("#upload-progress").is_visible()
    assert [len(batch) for batch in fake.uploads] == [8, 1, 1, 1, 1, 1, 1, 1, 1, 2]


def test_a_lost_upload_is_sent_again_and_batches_stay_under_the_bytes(page, console, tmp_path):
    """The first batch's answer is lost (502 after the files were stored): the batch is sent
    again whole and the server's `already_uploaded` keeps each image once. Batches are cut by
    bytes as well as by count (12 Mpx photos: ~5-8 MB each)."""
    console.allow.append("502")
    fake = FakeApi()
    fake.lose_next_upload = True
    open_fake(page, fake)
    names = [f"{i:02d}.jpg" for i in range(10)]
    for name in names:
        (tmp_path / name).write_bytes(b"\xff\xd8 a photo")
    page.locator("#images-panel summary").click()
    page.set_input_files("#upload-form input[type=file]", [str(tmp_path / n) for n in names])
    page.get_by_role("button", name="Upload", exact=True).click()
    page.wait_for_selector("#images-panel[data-uploaded='10'][data-refused='0']")
    assert [len(batch) for batch in fake.uploads] == [8, 8, 2]  # the first batch twice, whole
    assert "8 of them were already in the project" in page.inner_text("#upload-status")
    sizes = [40e6, 30e6, 1e6, 1e6, 70e6, 5e6]
    cut = page.evaluate("s => import('/js/upload.js').then((m) => m.batchesOf(s.map((size) => ({ size })))"
                        ".map((b) => b.length))", sizes)
    assert cut == [1, 3, 1, 1]  # 40 | 30+1+1 | 70 alone | 5


def test_an_absurd_placement_is_warned_and_question_mark_opens_the_keys(page):
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='5']").click()
    page.locator("#scene").focus()
    page.keyboard.press("Shift+ArrowUp")  # 0.5 units: nothing to say
    assert page.locator("#placement-warning").is_hidden()
    for _ in range(20):
        page.keyboard.press("Shift+ArrowUp")  # 10.5 units from its partners, range 2
    warning = page.locator("#placement-warning")
    warning.wait_for(state="visible")
    assert "0005.jpg" in warning.inner_text() and "Check the placement" in warning.inner_text()
    page.keyboard.press("?")
    assert page.locator("#keys-panel").get_attribute("open") is not None
    assert "Shift+wheel" in page.inner_text("#keys-panel")


def test_an_applied_edit_set_is_not_carried_onto_the_head_it_made(page):
    fake = FakeApi(head=2)
    fake.edit = {**stale_edit(1), "applied_version_id": 2}
    open_fake(page, fake)
    assert ("POST", "/api/v1/projects/1/edits/1/rebase") not in fake.log
    assert page.get_attribute("#scene", "data-moved") == "" and fake.edit["base_version_id"] == 1


def test_hovering_a_selected_camera_keeps_it_shown_as_selected(page):
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='3']").click()
    page.locator("#strip .thumb[data-id='3']").hover()
    page.wait_for_function("document.querySelector('#scene').dataset.hovered === '3'")
    scale = view(page)[2]
    *centre, _ = pixel(page, 2.0, 0.0)  # camera 3 sits at (2, 0)
    *ring, _ = pixel(page, 2.0 - 8 / scale, 0.0)
    assert max(abs(a - b) for a, b in zip(centre, (0xDD, 0x6B, 0x20), strict=True)) < 40, centre  # selected
    assert max(abs(a - b) for a, b in zip(ring, (0x00, 0xA3, 0xC4), strict=True)) < 60, ring  # hover ring


def test_a_known_distance_makes_the_scale_bar_speak_metres(page):
    """Cameras 1 and 3 are 2 units apart; told they are 10 m apart, the bar is labelled in metres
    and its length in units is the metres over 5; the setting outlives a reload of the page."""
    fake = FakeApi()
    open_fake(page, fake)
    assert page.get_attribute("#scene", "data-scale-label").endswith(("unit", "units"))
    page.locator("#strip .thumb[data-id='1']").click()
    page.locator("#strip .thumb[data-id='3']").click(modifiers=["Control"])
    questions = []
    page.once("dialog", lambda d: (questions.append(d.message), d.accept("10")))
    page.get_by_role("button", name="Set scale…").click()
    page.wait_for_function("document.querySelector('#scene').dataset.scaleLabel.endsWith(' m')")
    label = page.get_attribute("#scene", "data-scale-label")
    length = float(page.get_attribute("#scene", "data-scale-bar"))
    assert "0001.jpg and 0003.jpg" in questions[0] and "2.00 units apart" in questions[0]
    assert abs(float(label.removesuffix(" m")) - 5 * length) < 1e-6, (label, length)
    page.reload()
    page.wait_for_selector("body[data-ready='1/1']")
    page.wait_for_function("document.querySelector('#scene').dataset.scaleLabel.endsWith(' m')")


def test_running_a_reconstruction_that_cuts_nothing_asks_first(page):
    fake = FakeApi()
    open_fake(page, fake)
    move(page, 2, "ArrowUp")  # a small step: the fake rule cuts nothing
    assert page.get_attribute("#cut-counter", "data-count") == "0"
    questions = []
    page.once("dialog", lambda d: (questions.append(d.message), d.dismiss()))
    page.get_by_role("button", name="Run reconstruction").click()
    page.wait_for_timeout(300)
    assert questions and "deletes no pair" in questions[0]
    assert not [e for e in fake.log if e[1].endswith("/apply")]
