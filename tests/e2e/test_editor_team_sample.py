"""Issue 18 on the rendered sample, with a real `guided-sfm serve --sample`: Fit frames its
cameras (the cameras' extent covers at least a third of the canvas's longer side)."""

from __future__ import annotations

import pytest

from tests.e2e.conftest import shot, sign_in
from tests.e2e.test_frontend import open_project

pytestmark = [pytest.mark.browser, pytest.mark.slow]  # a real server reconstructs the sample


def test_fit_frames_the_sample_cameras(page, server, sample_project):
    sign_in(page, server)
    open_project(page, sample_project)
    page.locator("#scene").focus()
    page.keyboard.press("-")
    page.keyboard.press("-")
    page.locator("#fit-view").click()
    # a function, not an expression: polling evaluates an expression with eval, which the CSP refuses
    page.wait_for_function("() => document.querySelector('#scene').dataset.view.split(',')[2] > 0")
    scene = server.get(f"/projects/{sample_project['id']}/versions/{sample_project['head_version_id']}/scene")
    xs = [c["x"] for c in scene["cameras"] if c["x"] is not None]
    ys = [c["y"] for c in scene["cameras"] if c["y"] is not None]
    width, height = page.evaluate("(c => [c.width, c.height])(document.querySelector('#scene'))")
    scale = float(page.get_attribute("#scene", "data-view").split(",")[2])
    span = max(max(xs) - min(xs), max(ys) - min(ys)) * scale
    assert span >= max(width, height) / 3, (span, width, height)
    assert page.get_attribute("#scene", "data-order-segments") == str(len(xs) - 1)
    shot(page, "team-sample-fit")
