"""Editor details in headless Chromium against the in-memory fake of the REST contract (fake_api):
dropping an unregistered image, FoV/range sliders, flags, the matching panel, the split warning,
a read-only version and hover links. Fast: no server, no reconstruction."""

from __future__ import annotations

import json
import math

import pytest
from playwright.sync_api import expect

from tests.e2e.conftest import shot
from tests.e2e.fake_api import ORIGIN, FakeApi, camera

pytestmark = pytest.mark.browser


def open_fake(page, fake: FakeApi, route: str = "#/p/1") -> None:
    fake.install(page)
    page.goto(f"{ORIGIN}/")
    form = page.locator("#sign-in-form")
    form.get_by_label("Username").fill("fake-user")
    form.get_by_label("Password").fill("fake-password")
    form.get_by_role("button", name="Sign in").click()
    page.wait_for_selector("body[data-ready=projects]")
    page.evaluate("r => { location.hash = r; }", route)
    version = route.split("/v/")[1] if "/v/" in route else str(fake.head)
    page.wait_for_selector(f"body[data-ready='1/{version}']")


def saved(page, fake: FakeApi) -> dict:
    page.wait_for_selector("#cut-counter[data-state=ready]")
    return fake.edit


def world_to_client(page, x: float, y: float) -> tuple[float, float]:
    box = page.locator("#scene").bounding_box()
    cx, cy, scale = map(float, page.get_attribute("#scene", "data-view").split(","))
    return box["x"] + box["width"] / 2 + (x - cx) * scale, box["y"] + box["height"] / 2 - (y - cy) * scale


def test_drop_unregistered_image_sliders_and_flags(page):
    fake = FakeApi()
    open_fake(page, fake)
    thumb = page.locator("#strip .thumb[data-id='6']")
    assert "unregistered" in thumb.get_attribute("class")
    thumb.drag_to(page.locator("#scene"), target_position={"x": 300, "y": 200})
    camera = next(c for c in saved(page, fake)["cameras"] if c["image_id"] == 6)
    box = page.locator("#scene").bounding_box()
    cx, cy, scale = map(float, page.get_attribute("#scene", "data-view").split(","))
    assert math.isclose(camera["x"], cx + (300 - box["width"] / 2) / scale, abs_tol=2 / scale)
    assert math.isclose(camera["y"], cy - (200 - box["height"] / 2) / scale, abs_tol=2 / scale)
    assert "placed" in thumb.get_attribute("class")
    assert "6" in page.get_attribute("#scene", "data-moved").split(",")

    page.locator("#strip .thumb[data-id='2']").click()
    page.locator("#fov-slider").focus()
    for _ in range(5):
        page.keyboard.press("ArrowRight")
    page.locator("#range-slider").focus()
    page.keyboard.press("End")
    edit = {c["image_id"]: c for c in saved(page, fake)["cameras"]}
    assert edit[2]["fov_deg"] == 65 and math.isclose(edit[2]["range"], 4 * 2.0)
    page.locator("#scene").focus()
    page.keyboard.press("f")
    page.keyboard.press("t")
    assert saved(page, fake)["flags"] == [2]

    start = world_to_client(page, 3.0, 0.0)  # drag camera 4 with the mouse, 60 px to the right
    scale = float(page.get_attribute("#scene", "data-view").split(",")[2])
    page.mouse.move(*start)
    page.mouse.down()
    for dx in (20, 40, 60):
        page.mouse.move(start[0] + dx, start[1])
    page.mouse.up()
    dragged = next(c for c in saved(page, fake)["cameras"] if c["image_id"] == 4)
    assert math.isclose(dragged["x"], 3.0 + 60 / scale, abs_tol=1.5 / scale)
    assert math.isclose(dragged["y"], 0.0, abs_tol=1.5 / scale)
    assert "flagged" in page.locator("#strip .thumb[data-id='2']").get_attribute("class")
    assert page.get_attribute("#show-frusta", "aria-pressed") == "true"
    shot(page, "offline-drop-sliders-flags")


def test_matching_panel_deletions_and_split_warning(page):
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='3']").click()
    page.locator("#matching-panel summary").click()
    rows = page.locator("#match-list li")
    expect(rows).to_have_count(4)  # the list is built when the panel opens
    assert [r.get_attribute("data-pair") for r in rows.all()] == ["3-4", "2-3", "3-5", "1-3"]
    rows.nth(0).locator("input").check()
    rows.nth(1).locator("input").check()
    page.get_by_role("button", name="Delete selected matching").click()
    assert sorted(saved(page, fake)["delete_pairs"]) == [[2, 3], [3, 4]]
    assert page.get_attribute("#scene", "data-red-lines") == "2"
    assert page.locator("#match-list li.deleted").count() == 2
    page.locator("#scene").focus()
    page.keyboard.press("m")
    assert page.get_attribute("#show-matching", "aria-pressed") == "true"
    assert int(page.get_attribute("#scene", "data-lines")) == 4  # camera 3's four pairs
    assert page.locator("#split-warning").is_hidden()

    page.locator("#strip .thumb[data-id='5']").click()
    page.locator("#scene").focus()
    for _ in range(4):  # 4 x (5 steps of 5% of the range 2) = 2 units away from its partners
        page.keyboard.press("Shift+ArrowRight")
    preview = saved(page, fake)
    assert sorted(c["image_id"] for c in preview["cameras"]) == [5]
    warning = page.locator("#split-warning")
    warning.wait_for(state="visible")
    assert warning.get_attribute("role") == "alert" and "split from 1 into 2" in warning.inner_text()
    shot(page, "offline-split-warning")


def test_read_only_version_and_hover_links(page):
    fake = FakeApi(head=2)
    open_fake(page, fake, "#/p/1/v/1")
    assert "read-only" in page.inner_text("#banner")
    assert page.get_attribute("#scene", "data-editable") == "false"
    page.locator("#strip .thumb[data-id='2']").click()
    page.locator("#scene").focus()
    page.keyboard.press("ArrowRight")
    assert "Editing is locked" in page.inner_text("#notice")
    assert page.get_attribute("#scene", "data-moved") == ""
    assert not [entry for entry in fake.log if entry[0] in ("POST", "PUT") and "/edits" in entry[1]]

    page.locator("#strip .thumb[data-id='4']").hover()
    page.wait_for_function("document.querySelector('#scene').dataset.hovered === '4'")
    page.mouse.move(*world_to_client(page, 2.0, 0.0))  # camera 3 sits at (2, 0)
    page.wait_for_selector("#strip .thumb[data-id='3'].hovered")
    page.locator("#versions-panel summary").click()
    rows = page.locator("#version-list li")
    expect(rows).to_have_count(2)
    assert "head" in rows.nth(0).inner_text() and "on screen" in rows.nth(1).inner_text()
    shot(page, "offline-read-only")


def press_in_one_task(page, *keys: tuple[str, bool]) -> dict:
    """Dispatch key presses on the scene and read the preview counter in the same JS task, before
    the debounced save can answer: what the counter shows while the server's preview is stale."""
    return page.evaluate("""keys => {
        const scene = document.querySelector('#scene');
        for (const [key, shiftKey] of keys) {
            scene.dispatchEvent(new KeyboardEvent('keydown', {key, shiftKey, bubbles: true}));
        }
        const c = document.querySelector('#cut-counter');
        return {state: c.dataset.state, estimate: c.dataset.estimate, count: c.dataset.count,
                shown: c.querySelector('.count').textContent, note: c.querySelector('.note').textContent,
                red: document.querySelector('#scene').dataset.redLines};
    }""", [list(k) for k in keys])


def test_instant_estimate_is_labelled_as_the_papers_triangle_test(page):
    """Camera 5 moved 0.4 to the right: its triangle no longer meets camera 3's (2.4 apart, the
    triangles are 2.31 wide), so the browser's estimate of the paper's test cuts (3, 5); the
    fake server's rule cuts only beyond 2.5, so its count is 0. Each count says what it is."""
    fake = FakeApi()
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='5']").click()
    stale = press_in_one_task(page, ("ArrowRight", True), ("ArrowLeft", False))
    assert stale["state"] == "stale" and stale["estimate"] == "1" and stale["shown"] == "≈1"
    assert "estimate" in stale["note"] and "paper's triangle test" in stale["note"]
    assert 'server\'s "default" rule' in stale["note"] and stale["red"] == "1"
    shot(page, "offline-estimate")
    assert math.isclose(next(c for c in saved(page, fake)["cameras"] if c["image_id"] == 5)["x"], 4.4)
    counter = page.locator("#cut-counter")
    assert counter.get_attribute("data-count") == "0" and counter.get_attribute("data-estimate") == ""
    assert page.inner_text("#cut-counter .count") == "0"
    assert page.inner_text("#cut-counter .note") == 'pairs the server\'s "default" rule would delete'
    assert page.get_attribute("#scene", "data-red-lines") == "0"


# Version 1 of a folded run: cameras 2-5 sat on a diagonal; version 2 (the head) put them back in
# the row. Only camera 1 stayed, so a fit on the unmoved cameras has too few to work with.
FOLDED = [camera(1, 0.0), camera(2, 1.0, y=1.0), camera(3, 0.5, y=1.5), camera(4, 0.0, y=2.0),
          camera(5, -0.5, y=2.5), camera(6, None, False)]


def compare_with_v1(page, fake: FakeApi) -> dict:
    open_fake(page, fake)
    page.locator("#versions-panel summary").click()
    page.locator("#version-list li[data-version-id='1']").get_by_role("button", name="Compare").click()
    page.wait_for_selector("#compare-summary[data-moved]")
    return page.eval_on_selector("#compare-summary", "e => ({...e.dataset, text: e.textContent})")


def test_compare_arrows_start_where_the_cameras_were(page):
    """The server keeps versions in one frame and says which cameras moved: each arrow runs from
    the camera's place in v1 to its place on screen, as long as the server says it moved."""
    fake = FakeApi(head=2, older={1: FOLDED})
    summary = compare_with_v1(page, fake)
    arrows = {a["id"]: a for a in json.loads(summary["arrows"])}
    assert sorted(arrows) == [2, 3, 4, 5] and summary["sharedFrame"] == "true"
    moved = {c["image_id"]: c["moved"] for c in fake.compare(1, 2)}
    for cam in FOLDED[1:5]:
        arrow = arrows[cam["image_id"]]
        assert arrow["from"] == pytest.approx([cam["x"], cam["y"]], abs=1e-9), arrow
        assert arrow["to"] == pytest.approx([cam["image_id"] - 1.0, 0.0], abs=1e-9)
        assert math.dist(arrow["from"], arrow["to"]) == pytest.approx(moved[cam["image_id"]], abs=1e-9)
    assert page.get_attribute("#scene", "data-arrows") == "4"
    assert "4 of 5 cameras moved (arrows)" in summary["text"]
    shot(page, "offline-compare-arrows")
    page.get_by_role("button", name="Clear comparison").click()
    assert page.get_attribute("#scene", "data-arrows") == "0"


def test_compare_with_a_version_in_another_frame_draws_no_arrows(page):
    """A separate reconstruction is not aligned to earlier versions: v1 is the head turned by 90
    degrees. The server (aligning the two itself) says only camera 5 moved; the cameras it calls
    unmoved are far from where v1 has them, so the panel draws no arrows and says why."""
    turned = [camera(c["image_id"], -c["y"], y=c["x"]) if c["center"] else c for c in FakeApi().cameras]
    answer = [{"image_id": i, "moved": 1.0 if i == 5 else 0.0, "rotated_deg": 0.0} for i in range(1, 6)]
    summary = compare_with_v1(page, FakeApi(head=2, older={1: turned}, compare=answer))
    assert summary["moved"] == "1" and summary["sharedFrame"] == "false"
    assert json.loads(summary["arrows"]) == [] and page.get_attribute("#scene", "data-arrows") == "0"
    assert "v1 is in another frame" in summary["text"]


def test_matching_panel_pages_through_many_partners(page):
    """A camera matched to 119 others (as at 1,000 cameras): 50 rows a page, most inliers first,
    the pager moves through them, and another camera starts on its first page."""
    fake = FakeApi()
    fake.cameras = [camera(i, float(i - 1)) for i in range(1, 121)]
    fake.pairs = {(1, j): 1000 - j for j in range(2, 121)} | {(2, 3): 10}
    open_fake(page, fake)
    page.locator("#strip .thumb[data-id='1']").click()
    page.locator("#matching-panel summary").click()
    rows = page.locator("#match-list li")
    expect(rows).to_have_count(50)
    expect(page.locator("#match-range")).to_have_text("1-50 of 119")
    assert rows.first.get_attribute("data-pair") == "1-2"  # the most inliers
    assert page.locator("#match-prev").is_disabled()
    page.locator("#match-next").click()
    expect(page.locator("#match-range")).to_have_text("51-100 of 119")
    assert rows.first.get_attribute("data-pair") == "1-52"
    page.locator("#match-next").click()
    expect(rows).to_have_count(19)
    assert page.locator("#match-next").is_disabled()
    rows.nth(18).locator("input").check()
    page.get_by_role("button", name="Delete selected matching").click()
    assert saved(page, fake)["delete_pairs"] == [[1, 120]]
    page.locator("#match-prev").click()
    expect(page.locator("#match-range")).to_have_text("51-100 of 119")
    page.locator("#strip .thumb[data-id='3']").click()
    expect(rows).to_have_count(2)
    assert page.locator("#match-pager").is_hidden()


def test_the_editor_draws_the_servers_level_then_asks_for_every_point(page):
    """A decimated point layer first (points.total says more are kept), then ?max_points=."""
    fake = FakeApi()
    fake.decimate = True
    open_fake(page, fake)
    expect(page.locator("#scene")).to_have_attribute("data-points", str(len(fake.points)))
    scene_gets = [path for method, path in fake.log if path.endswith("/scene")]
    assert len(scene_gets) == 2  # the server's level, then all (the log keeps paths, not queries)
