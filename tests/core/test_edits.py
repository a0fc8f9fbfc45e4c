"""The one parser of an edit set: every value checked and named once, at the edge; the rule names
and their default in one place."""

import math

import pytest

from guided_sfm.cli import build_parser
from guided_sfm.core.edits import edits_to_json, parse_edits
from guided_sfm.core.errors import InvalidInput, UnknownImage
from guided_sfm.core.types import DEFAULT_RULE, RULES, CameraEdit, EditSet

IDS = {"a.jpg": 1, "b.jpg": 2, "c.jpg": 3}


def camera(ref="a.jpg", **extra):
    return {"name": ref, "x": 1.0, "y": 2.0, "yaw_deg": 90.0, **extra}


def test_the_default_rule_is_default_everywhere():
    assert DEFAULT_RULE == "default" and set(RULES) == {"default", "paper"}
    assert EditSet().rule == DEFAULT_RULE
    assert parse_edits({}, IDS).rule == DEFAULT_RULE
    assert parse_edits({"rule": None}, IDS).rule == DEFAULT_RULE
    assert build_parser().parse_args(["demo"]).rule == DEFAULT_RULE


def test_a_body_by_name_or_id_parses_and_writes_back():
    body = {"cameras": [camera(fov_deg=60, range=2.5), {"image_id": 2, "x": 0, "y": 0, "yaw_deg": 0}],
            "delete_pairs": [["c.jpg", "a.jpg"], [2, 1]], "rule": "paper",
            "tolerances": {"placement_deg": 30}}
    edits = parse_edits(body, IDS)
    assert edits.cameras == [CameraEdit(1, 1.0, 2.0, 90.0, 60.0, 2.5), CameraEdit(2, 0.0, 0.0, 0.0)]
    assert edits.delete_pairs == [(1, 2), (1, 3)] and edits.rule == "paper"
    assert edits.tolerances == {"placement_deg": 30.0}
    assert parse_edits(edits_to_json(edits), IDS) == edits


BAD = {
    "fov 0": ({"cameras": [camera(fov_deg=0)]}, "camera a.jpg: fov_deg must be in (0, 180)"),
    "fov 180": ({"cameras": [camera(fov_deg=180)]}, "fov_deg must be in (0, 180)"),
    "fov -30": ({"cameras": [camera(fov_deg=-30)]}, "fov_deg must be in (0, 180)"),
    "fov nan": ({"cameras": [camera(fov_deg=math.nan)]}, "fov_deg must be a finite number"),
    "range 0": ({"cameras": [camera(range=0)]}, "camera a.jpg: range must be > 0"),
    "range -1": ({"cameras": [camera(range=-1)]}, "range must be > 0"),
    "range inf": ({"cameras": [camera(range=math.inf)]}, "range must be a finite number"),
    "x nan": ({"cameras": [camera(x=math.nan)]}, "camera a.jpg: x must be a finite number"),
    "yaw inf": ({"cameras": [camera(yaw_deg=-math.inf)]}, "yaw_deg must be a finite number"),
    "y text": ({"cameras": [camera(y="north")]}, "y must be a finite number"),
    "x bool": ({"cameras": [camera(x=True)]}, "x must be a finite number"),
    "no yaw": ({"cameras": [{"name": "a.jpg", "x": 0, "y": 0}]}, "missing field yaw_deg"),
    "not an object": ({"cameras": [7]}, "each camera must be an object"),
    "twice": ({"cameras": [camera(), camera(x=3.0)]}, "a camera appears twice"),
    "self pair": ({"delete_pairs": [["a.jpg", 1]]}, "a pair needs two different images"),
    "short pair": ({"delete_pairs": [[1]]}, "must be two images"),
    "bad rule": ({"rule": "magic"}, "unknown rule 'magic'"),
    "tolerances list": ({"tolerances": [1, 2]}, "tolerances must be an object"),
    "bad tolerance": ({"tolerances": {"two_view_deg": -1}}, "two_view_deg must be a finite number > 0"),
    "unknown tolerance": ({"tolerances": {"magic_deg": 3}}, "unknown tolerance 'magic_deg'"),
    "body list": ([], "must be a JSON object"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_value_is_refused_naming_it(case):
    body, message = BAD[case]
    with pytest.raises(InvalidInput) as error:
        parse_edits(body, IDS)
    assert message in str(error.value)


@pytest.mark.parametrize(("body", "message"), [
    ({"cameras": [camera("z.jpg")]}, "unknown image name 'z.jpg'"),
    ({"cameras": [{"image_id": 9, "x": 0, "y": 0, "yaw_deg": 0}]}, "unknown image id 9"),
    ({"delete_pairs": [[1, 77]]}, "unknown image id 77"),
])
def test_an_unknown_image_is_refused(body, message):
    with pytest.raises(UnknownImage, match=message):
        parse_edits(body, IDS)
