import dataclasses

import numpy as np
import pytest

from guided_sfm.core.errors import InvalidFrustum, InvalidInput
from guided_sfm.core.rule.driver import kept_to_connect, prune_pairs
from guided_sfm.core.types import CameraEdit, EditSet, GroundFrame, SceneCamera, TopDownScene
from tests.core.test_default_rule import _twins

FRAME = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                    np.array([0, 0, 1.0]))


def _camera(image_id, x=None, y=None, yaw=None, fov=60.0, range_=5.0):
    registered = x is not None
    return SceneCamera(image_id, f"{image_id:03d}.png", image_id, registered,
                       0 if registered else None, x, y, yaw, fov, range_,
                       (x, y, 0.0) if registered else None,
                       (1.0, 0.0, 0.0, 0.0) if registered else None)


def _scene(*cameras) -> TopDownScene:
    return TopDownScene(FRAME, list(cameras), np.zeros((0, 2)))


# A row of cameras 2 m apart all facing +y: neighbouring frusta overlap.
ROW = _scene(*[_camera(i, x=2.0 * i, y=0.0, yaw=90.0) for i in range(1, 6)], _camera(9))
ROW_PAIRS = {(1, 2): 50, (2, 3): 40, (3, 4): 30, (4, 5): 20, (1, 5): 10, (3, 9): 15}


def test_moved_camera_far_away_loses_its_pairs():
    edits = EditSet(cameras=[CameraEdit(3, x=100.0, y=100.0, yaw_deg=0.0)])
    result = prune_pairs(ROW, edits, ROW_PAIRS)
    assert result.deleted == [(2, 3), (3, 4)]
    assert result.reasons == {(2, 3): ("frustum",), (3, 4): ("frustum",)}
    assert result.removed_by_test == {"frustum": 2}


def test_pairs_between_unmoved_cameras_are_never_touched():
    # (1, 5) do not overlap (8 m apart, narrow), yet neither moved.
    scene = _scene(*[_camera(i, x=2.0 * i, y=0.0, yaw=90.0, fov=10.0) for i in range(1, 6)])
    edits = EditSet(cameras=[CameraEdit(3, x=4.0, y=-50.0, yaw_deg=-90.0)])
    result = prune_pairs(scene, edits, ROW_PAIRS)
    assert (1, 5) not in result.deleted
    assert result.deleted == [(2, 3), (3, 4)]


def test_unmoved_camera_in_place_keeps_its_pairs():
    edits = EditSet(cameras=[CameraEdit(3, x=6.0, y=0.0, yaw_deg=90.0)])
    assert prune_pairs(ROW, edits, ROW_PAIRS).deleted == []


def test_both_moved_uses_both_edited_poses():
    scene = _scene(_camera(1, x=0.0, y=0.0, yaw=0.0), _camera(2, x=100.0, y=0.0, yaw=0.0))
    pairs = {(1, 2): 30}
    together = EditSet(cameras=[CameraEdit(1, 50.0, 0.0, 0.0), CameraEdit(2, 52.0, 0.0, 180.0)])
    assert prune_pairs(scene, together, pairs).deleted == []
    apart = EditSet(cameras=[CameraEdit(1, 50.0, 0.0, 180.0), CameraEdit(2, 52.0, 0.0, 0.0)])
    assert prune_pairs(scene, apart, pairs).deleted == [(1, 2)]


def test_edit_fov_and_range_override_the_scene():
    scene = _scene(_camera(1, x=0.0, y=0.0, yaw=0.0), _camera(2, x=3.0, y=0.0, yaw=90.0))
    pairs = {(1, 2): 30}
    assert prune_pairs(scene, EditSet([CameraEdit(1, 0.0, 0.0, 0.0)]), pairs).deleted == []
    short = EditSet([CameraEdit(1, 0.0, 0.0, 0.0, range=1.0)])
    assert prune_pairs(scene, short, pairs).deleted == [(1, 2)]
    narrow_far = EditSet([CameraEdit(1, 0.0, -1.0, 0.0, fov_deg=1.0)])
    assert prune_pairs(scene, narrow_far, pairs).deleted == [(1, 2)]


def test_unplaced_unregistered_image_takes_no_test_until_placed():
    edits = EditSet(cameras=[CameraEdit(3, x=100.0, y=100.0, yaw_deg=0.0)])
    assert (3, 9) not in prune_pairs(ROW, edits, ROW_PAIRS).deleted
    placed = EditSet(cameras=[CameraEdit(9, x=-50.0, y=0.0, yaw_deg=180.0)])
    assert prune_pairs(ROW, placed, ROW_PAIRS).deleted == [(3, 9)]


def test_unregistered_image_without_fov_needs_one_when_placed():
    scene = _scene(_camera(1, x=0.0, y=0.0, yaw=0.0), _camera(2, fov=None))
    with pytest.raises(InvalidFrustum, match="camera 2"):
        prune_pairs(scene, EditSet([CameraEdit(2, 1.0, 0.0, 0.0)]), {(1, 2): 5})
    edits = EditSet([CameraEdit(2, 1.0, 0.0, 180.0, fov_deg=60.0)])
    assert prune_pairs(scene, edits, {(1, 2): 5}).deleted == []


def test_manual_deletions_are_applied_as_given():
    edits = EditSet(cameras=[CameraEdit(3, 100.0, 100.0, 0.0)], delete_pairs=[(5, 4), (3, 2)])
    result = prune_pairs(ROW, edits, ROW_PAIRS)
    assert result.deleted == [(2, 3), (3, 4), (4, 5)]
    assert result.reasons[(4, 5)] == ("manual",)
    assert result.reasons[(2, 3)] == ("frustum", "manual")
    assert result.removed_by_test == {"frustum": 2, "manual": 2}


def test_manual_deletion_of_a_pair_that_is_not_verified():
    # the parser knows the images (tests/core/test_edits.py), the rule the version's pairs
    with pytest.raises(InvalidInput, match=r"\(1, 3\) is not a verified pair"):
        prune_pairs(ROW, EditSet(delete_pairs=[(1, 3)]), ROW_PAIRS)


def test_rules_dispatch():
    edits = [CameraEdit(3, 100.0, 100.0, 0.0)]
    paper = prune_pairs(ROW, EditSet(edits, rule="paper"), ROW_PAIRS)
    assert prune_pairs(ROW, EditSet(edits, rule="default"), ROW_PAIRS) == paper  # no evidence


def test_no_edits_delete_nothing():
    assert prune_pairs(ROW, EditSet(), ROW_PAIRS).deleted == []
    assert prune_pairs(ROW, EditSet([CameraEdit(1, 0.0, 0.0, 0.0)]), {}).deleted == []


def test_the_default_rule_keeps_placement_only_cuts_that_would_split_the_match_graph():
    pairs = {(1, 2): 90, (2, 3): 40, (1, 4): 60, (3, 4): 200, (2, 4): 25, (5, 6): 30}
    reasons = {(2, 3): ("placement",), (1, 4): ("placement", "rotation"),
               (2, 4): ("placement",), (3, 4): ("placement", "relative_pose")}
    # 3 and 4 would lose every link: the placement-only links that join them back stay, the
    # pairs another test also cut go.
    assert kept_to_connect(pairs, reasons, manual=[]) == [(2, 3), (2, 4)]
    # a manual deletion is the user's own: never kept, and a split it makes is not undone
    assert kept_to_connect(pairs, {(2, 3): ("placement",)}, manual=[(2, 4), (1, 4)]) == [(2, 3)]
    assert kept_to_connect(pairs, {}, manual=[(2, 3), (2, 4), (1, 4)]) == []
    # no split, nothing kept
    assert kept_to_connect(pairs, {(2, 3): ("placement",), (2, 4): ("placement",)}, []) == []


def test_the_driver_with_evidence_tests_only_pairs_of_moved_cameras():
    """The default rule with its evidence (hand-made twins, tests/core/test_default_rule.py): only
    camera 7 of the folded cluster is carried back, so only pairs of 7 go (its false pairs, and its
    pairs with the cluster still folded), by the evidence tests; the other false pairs stay until
    their cameras are moved; a manual deletion joins the reasons."""
    capture, _, false = _twins(np.random.default_rng(1))
    edits = capture.placement({7}, shift=0.3, turn_deg=-10.0)
    result = prune_pairs(capture.scene(), edits, capture.pairs(), capture.evidence())
    mine = {p for p in capture.pairs() if 7 in p}
    assert false & mine <= set(result.deleted) <= mine and len(false - mine) >= 4
    assert all(set(result.reasons[p]) <= {"placement", "relative_pose", "rotation"} for p in result.deleted)
    assert "frustum" not in result.removed_by_test  # every pair has evidence
    manual = min(false - mine)
    with_manual = prune_pairs(capture.scene(), dataclasses.replace(edits, delete_pairs=[manual]),
                              capture.pairs(), capture.evidence())
    assert set(with_manual.deleted) == set(result.deleted) | {manual}
    assert with_manual.reasons[manual] == ("manual",)
    paper = prune_pairs(capture.scene(), dataclasses.replace(edits, rule="paper"), capture.pairs())
    assert set(paper.deleted).isdisjoint(false)  # the twins' frusta overlap: the paper's rule misses them
