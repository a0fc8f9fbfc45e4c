"""The editor's triage tools (issue 21) in headless Chromium against the in-memory fake of the REST
contract (fake_api), on hand-made answers whose every figure is known: the suspect queue, proposals
(accept, undo, dismiss), the path tool (polyline, orbit) and a split-off model moved as one group.
test_triage.py runs the same tools against a real server."""

from __future__ import annotations

import math
import re

import pytest
from playwright.sync_api import expect

from tests.e2e.conftest import shot
from tests.e2e.fake_api import FakeApi, camera
from tests.e2e.test_editor_offline import open_fake, saved, world_to_client

pytestmark = pytest.mark.browser

# Cameras 1-5 stand in a row at x = 0..4 (y = 0, looking along +y): one unit apart.
PROPOSAL = [{"image_id": 4, "x": 3.0, "y": 2.0, "yaw_deg": 45.0},
            {"image_id": 5, "x": 4.0, "y": 2.5, "yaw_deg": 50.0}]
TRIAGE = {
    "suspects": [{"image_id": 4, "score": 0.9,
                  "reasons": ["4.1 steps from #3", "turns 80° against the capture"]},
                 {"image_id": 5, "score": 0.5, "reasons": ["joined to the rest through repeated texture"]},
                 {"image_id": 2, "score": 0.49, "reasons": ["just below the threshold"]},
                 {"image_id": 3, "score": 0.7, "reasons": ["matched none of 40 points it should see"]}],
    "runs": [{"image_ids": [4, 5], "reason": "#4-#5 continue #1-#3's trajectory",
              "proposal": {"cameras": PROPOSAL}},
             {"image_ids": [3], "reason": "no proposal", "proposal": None}],
}


def edited(page, fake: FakeApi) -> dict[int, dict]:
    return {c["image_id"]: c for c in saved(page, fake)["cameras"]}


def open_triage(page, fake: FakeApi) -> None:
    fake.suspects = TRIAGE
    open_fake(page, fake)
    page.wait_for_selector("#triage-panel[data-state=ready]")


def test_queue_raised_at_half_sorted_with_reasons_and_hover_links(page):
    fake = FakeApi()
    open_triage(page, fake)
    entries = page.locator("#suspect-list > li")
    assert [e.get_attribute("data-image-id") for e in entries.all()] == ["4", "3", "5"]  # 0.49 stays down
    assert page.get_attribute("#suspect-count", "data-count") == "3"
    assert entries.nth(0).locator(".reasons li").all_inner_texts() == TRIAGE["suspects"][0]["reasons"]
    assert entries.nth(0).locator(".score").inner_text() == "0.90"
    entries.nth(1).hover()
    page.wait_for_function("() => document.querySelector('#scene').dataset.hovered === '3'")
    expect(page.locator("#strip .thumb[data-id='3']")).to_have_class(re.compile(r"\bhovered\b"))
    page.mouse.move(*world_to_client(page, 3.0, 0.0))  # and back: camera 4 hovered in the scene
    expect(entries.nth(0)).to_have_class(re.compile(r"\bhovered\b"))
    entries.nth(2).get_by_role("button").click()  # camera 5: its run is selected
    assert page.get_attribute("#scene", "data-selected") == "4,5"
    entries.nth(0).get_by_role("button").click(modifiers=["Control"])
    assert page.get_attribute("#scene", "data-selected") == "4"
    page.locator("#scene").focus()
    for _ in range(15):  # pan a view and a half away: a picked suspect is brought back into view
        page.keyboard.press("Alt+ArrowLeft")
    entries.nth(1).get_by_role("button").click()
    page.wait_for_function("() => document.querySelector('#scene').dataset.view.startsWith('2,0,')")
    shot(page, "offline-triage-queue")


def test_accept_undo_and_dismiss_a_proposal(page):
    fake = FakeApi()
    open_triage(page, fake)
    assert page.get_attribute("#scene", "data-ghosts") == "2"
    run = page.locator("#run-list li[data-run='4-5']")
    run.get_by_role("button", name="Accept").click()
    cameras = edited(page, fake)
    for proposed in PROPOSAL:
        got = cameras[proposed["image_id"]]
        assert (got["x"], got["y"], got["yaw_deg"]) == (proposed["x"], proposed["y"], proposed["yaw_deg"])
        assert got["fov_deg"] == 60.0 and got["range"] == 2.0  # the camera's own frustum
    assert run.get_attribute("data-state") == "accepted"
    assert page.get_attribute("#scene", "data-ghosts") == "0"
    page.locator("#scene").focus()
    page.keyboard.press("ArrowUp")  # an accepted proposal is an ordinary move: the keys go on from it
    page.keyboard.press("Control+z")
    page.keyboard.press("Control+z")
    assert saved(page, fake)["cameras"] == []
    assert run.get_attribute("data-state") == "open" and page.get_attribute("#scene", "data-ghosts") == "2"
    run.get_by_role("button", name="Dismiss").click()
    expect(run).to_have_count(0)
    assert page.get_attribute("#scene", "data-ghosts") == "0"
    page.reload()  # dismissed for this version in this tab
    page.wait_for_selector("#triage-panel[data-state=ready]")
    assert page.locator("#run-list li").count() == 1 and page.get_attribute("#scene", "data-ghosts") == "0"
    page.get_by_role("button", name="Show 1 dismissed").click()
    assert page.get_attribute("#scene", "data-ghosts") == "2"


def test_adjust_selects_the_run_at_the_proposed_poses(page):
    fake = FakeApi()
    open_triage(page, fake)
    page.locator("#run-list li[data-run='4-5']").get_by_role("button", name="Adjust").click()
    assert page.get_attribute("#scene", "data-selected") == "4,5"
    page.keyboard.press("ArrowRight")  # the scene has focus: one step of 5% of the range 2
    cameras = edited(page, fake)
    assert cameras[4]["x"] == pytest.approx(3.1) and cameras[5]["x"] == pytest.approx(4.1)
    assert cameras[4]["y"] == 2.0 and cameras[5]["yaw_deg"] == 50.0


def select_all_five(page) -> None:
    page.locator("#strip .thumb[data-id='1']").click()
    page.locator("#strip .thumb[data-id='5']").click(modifiers=["Shift"])
    assert page.get_attribute("#scene", "data-selected") == "1,2,3,4,5"


def test_lay_a_stretch_along_a_polyline(page):
    """Five cameras one unit apart laid along an L: (-0.3, 1) -> (2.5, 1) -> (2.5, 2.5), at their step
    1 (no camera lands on the corner, where a pixel decides which leg's heading it takes)."""
    fake = FakeApi()
    open_triage(page, fake)
    select_all_five(page)
    page.locator("#scene").focus()
    page.keyboard.press("l")
    assert page.get_attribute("#path-panel", "data-tool") == "polyline"
    corners = [(-0.3, 1.0), (2.5, 1.0), (2.5, 2.5)]
    for x, y in corners[:-1]:
        page.mouse.click(*world_to_client(page, x, y))
    page.mouse.dblclick(*world_to_client(page, *corners[-1]))
    assert page.get_attribute("#path-panel", "data-tool") == ""
    cameras = edited(page, fake)
    tol = 1.5 / float(page.get_attribute("#scene", "data-view").split(",")[2])  # a click lands within a pixel
    expected = [(-0.3, 1, 0), (0.7, 1, 0), (1.7, 1, 0), (2.5, 1.2, 90), (2.5, 2.2, 90)]
    for image_id, (x, y, yaw) in zip(range(1, 6), expected, strict=True):
        got = cameras[image_id]
        assert got["x"] == pytest.approx(x, abs=2 * tol) and got["y"] == pytest.approx(y, abs=2 * tol), got
        assert got["yaw_deg"] == pytest.approx(yaw, abs=2), got
    assert float(page.get_attribute("#path-panel", "data-spacing")) == pytest.approx(1.0)
    page.keyboard.press("Control+z")  # one undo step
    assert saved(page, fake)["cameras"] == []
    shot(page, "offline-path-polyline")


def test_lay_a_stretch_around_a_circle_looking_at_the_centre(page):
    """An orbit of radius 1.5 about (2, 1), starting due south of it: the stretch does not turn, so
    it goes counter-clockwise, one unit (1/1.5 rad) apart, each camera looking at the centre."""
    fake = FakeApi()
    open_triage(page, fake)
    select_all_five(page)
    page.select_option("#path-yaw", "centre")
    page.locator("#draw-orbit").click()
    centre, start = world_to_client(page, 2.0, 1.0), world_to_client(page, 2.0, -0.5)
    page.mouse.move(*centre)
    page.mouse.down()
    page.mouse.move((centre[0] + start[0]) / 2, (centre[1] + start[1]) / 2)
    page.mouse.move(*start)
    page.mouse.up()
    cameras = edited(page, fake)
    tol = 2 / float(page.get_attribute("#scene", "data-view").split(",")[2])
    for i in range(5):
        theta = -math.pi / 2 + i / 1.5
        got = cameras[i + 1]
        assert got["x"] == pytest.approx(2 + 1.5 * math.cos(theta), abs=3 * tol), got
        assert got["y"] == pytest.approx(1 + 1.5 * math.sin(theta), abs=3 * tol), got
        to_centre = math.degrees(math.atan2(1 - got["y"], 2 - got["x"]))
        assert abs((got["yaw_deg"] - to_centre + 180) % 360 - 180) < 1, got
    shot(page, "offline-path-circle")


def group_camera(image_id: int, x: float, y: float, yaw: float) -> dict:
    """A camera of the second model: no v1 pose, a group pose beside the largest model."""
    return {**camera(image_id, None, False), "model": 1, "group_pose": {"x": x, "y": y, "yaw_deg": yaw}}


def test_split_off_model_moves_as_one_group(page):
    fake = FakeApi()
    fake.cameras = [*fake.cameras[:5], group_camera(6, 0.0, 4.0, 0.0), group_camera(7, 1.0, 4.0, 0.0),
                    group_camera(8, 2.0, 4.0, 0.0)]
    open_fake(page, fake)
    assert page.get_attribute("#scene", "data-groups") == "1"
    expect(page.locator("#group-list li")).to_have_count(1)
    start = world_to_client(page, 1.0, 4.0)
    page.mouse.move(*start)
    page.mouse.down()  # one click selects the whole group, the drag moves it
    assert page.get_attribute("#scene", "data-selected") == "6,7,8"
    for dy in (10, 20, 30):
        page.mouse.move(start[0], start[1] + dy)
    page.mouse.up()
    scale = float(page.get_attribute("#scene", "data-view").split(",")[2])
    cameras = edited(page, fake)
    assert sorted(cameras) == [6, 7, 8]
    for image_id, x in ((6, 0.0), (7, 1.0), (8, 2.0)):
        assert cameras[image_id]["x"] == pytest.approx(x, abs=1.5 / scale)
        assert cameras[image_id]["y"] == pytest.approx(4.0 - 30 / scale, abs=1.5 / scale)
    page.keyboard.press("Shift+q")  # and turn it: 10 degrees about its centroid
    cameras = edited(page, fake)
    y0 = 4.0 - 30 / scale
    for image_id, x in ((6, 0.0), (7, 1.0), (8, 2.0)):
        rx = x - 1.0
        assert cameras[image_id]["x"] == pytest.approx(1.0 + rx * math.cos(math.radians(10)), abs=1.5 / scale)
        assert cameras[image_id]["y"] == pytest.approx(y0 + rx * math.sin(math.radians(10)), abs=1.5 / scale)
        assert cameras[image_id]["yaw_deg"] == pytest.approx(10.0)
    page.keyboard.press("Control+z")
    page.keyboard.press("Control+z")
    assert saved(page, fake)["cameras"] == []
    shot(page, "offline-group-move")
