"""The `separates` reason on a hand-made twin capture: a look-alike pair between two unmoved
cameras, one on each side of what the placement separates, is judged; a true one is kept."""

import numpy as np

from guided_sfm.core.rule.driver import prune_pairs
from guided_sfm.core.rule.separates import SEPARATES, partners_of_moved, separating_pairs

from .synthetic import Capture, ground_motion, look_at, scatter

EYE = 1.5
TWIN_SHIFT = np.array([10.0, 0.0, 0.0])  # twin B is twin A moved 10 m along x


def _twins(rng) -> tuple[Capture, dict[str, tuple[int, int]]]:
    """Cameras 1-3 face twin A, 4-7 twin B; 4 and 5 were folded onto A (shifted -10 m).

    True pairs within each twin; false (look-alike) pairs 4-1, 4-3 and 5-2 between a folded camera
    and A, and 6-2 between two unmoved cameras; a true pair 3-6 sees a wall between the twins."""
    centers = {1: (-2, -3), 2: (0, -3.5), 3: (2, -3), 4: (8, -3), 5: (10, -3.5), 6: (12, -3),
               7: (10, 3)}
    poses = {i: look_at(np.array([x, y, EYE]), (10.0 if i > 3 else 0.0, 0.0))
             for i, (x, y) in centers.items()}
    capture = Capture(poses, cluster={4, 5}, motion=ground_motion(0.0, -TWIN_SHIFT))
    twin_a = scatter(rng, 150, (-1, -1, 0.3), (1, 1, 2.3))
    for a, b in ((1, 2), (2, 3), (1, 3), (4, 5), (5, 6), (4, 6), (5, 7), (4, 7)):
        capture.match(a, b, twin_a + (TWIN_SHIFT if a > 3 else 0))
    for a, b in ((1, 4), (3, 4), (2, 5), (2, 6)):  # A's points matched with their look-alikes on B
        capture.match(a, b, twin_a, twin_a + TWIN_SHIFT)
    capture.match(3, 6, scatter(rng, 80, (4, 2, 0.3), (6, 3, 2.3)))  # between the twins
    return capture, {"false": (2, 6), "true": (3, 6)}


def test_a_look_alike_pair_no_moved_camera_touches_is_deleted_as_separates():
    capture, pairs_of = _twins(np.random.default_rng(0))
    edits = capture.placement({4, 5})
    result = prune_pairs(capture.scene(), edits, capture.pairs(), capture.evidence())
    assert {(1, 4), (3, 4), (2, 5)} <= set(result.deleted)  # the folded cameras' false pairs
    assert pairs_of["false"] in result.deleted
    assert result.reasons[pairs_of["false"]][0] == SEPARATES
    assert pairs_of["true"] not in result.deleted  # a candidate too (4 is apart from 3), kept
    assert (5, 6) not in result.deleted and (1, 2) not in result.deleted


def test_only_pairs_across_what_the_placement_separates_are_candidates():
    capture, pairs_of = _twins(np.random.default_rng(0))
    pairs = capture.pairs()
    tested = np.array([(1, 4), (2, 5), (3, 4), (4, 5), (4, 6), (4, 7), (5, 6), (5, 7)])
    removed = np.array([True, True, False, False, False, False, False, False])
    found = {tuple(p) for p in separating_pairs(pairs, tested, removed, {4, 5}).tolist()}
    # 5 goes with 6 and 7, not with 2; 4 goes with 3 (kept here), 6 and 7, not with 1: the
    # matched unmoved pairs across are 2-6 and 1-3 (2-3 is across no one camera's groups)
    assert found == {pairs_of["false"], (1, 3)}
    nothing_removed = separating_pairs(pairs, tested, np.zeros(len(tested), dtype=bool), {4, 5})
    assert len(nothing_removed) == 0
    # the user's own deletion of 4-3 puts 3 apart from 4, so 3-6 joins separated groups too
    untested = (tested != (3, 4)).any(axis=1)
    with_manual = separating_pairs(pairs, tested[untested], removed[untested], {4, 5},
                                   manual=[(3, 4)])
    assert {tuple(p) for p in with_manual.tolist()} == {pairs_of["false"], pairs_of["true"]}
    assert (1, 3) not in {tuple(p) for p in with_manual.tolist()}


def test_the_paper_rule_never_touches_a_pair_between_unmoved_cameras():
    capture, pairs_of = _twins(np.random.default_rng(0))
    edits = capture.placement({4, 5}, rule="paper")
    result = prune_pairs(capture.scene(), edits, capture.pairs(), capture.evidence())
    assert not any(4 not in key and 5 not in key for key in result.deleted)
    assert pairs_of["false"] not in result.deleted


def test_the_evidence_covers_the_candidates():
    capture, pairs_of = _twins(np.random.default_rng(0))
    needed = set(partners_of_moved(capture.pairs(), {5}))
    assert pairs_of["false"] in needed and (2, 5) in needed
    assert (1, 3) not in needed and (1, 4) not in needed  # 1 and 3 are no partners of 5
