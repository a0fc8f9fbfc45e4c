"""Triage's signals, runs and proposals on hand-made captures (no reconstruction)."""

import dataclasses

import numpy as np
import pytest

from guided_sfm.core.triage import other_models, poses2d, signals, symmetry
from guided_sfm.core.triage.evidence import MissingCount, TriageInput
from guided_sfm.core.triage.pieces import GROUP, PLACED, Piece
from guided_sfm.core.triage.suspects import RAISE_SCORE, triage
from guided_sfm.core.types import GroundFrame, SceneCamera, TopDownScene, pair_key

FRAME = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))


def camera(i, x, y, yaw, registered=True, group=None):
    pose = (x, y, yaw) if registered else (None, None, None)
    return SceneCamera(i + 1, f"{i:04d}.jpg", i, registered, 0 if registered else 1, *pose, 60.0,
                       3.0, (x, y, 1.5) if registered else None, None, group)


def capture(true_poses, placed_poses, registered=None, groups=None):
    """A scene of cameras at placed_poses; pairs between cameras within 2.5 m of each other in
    truth, whose 3D overlap is high where the placement agrees with the truth and nil where not."""
    n = len(true_poses)
    registered = registered or [True] * n
    groups = groups or {}
    cams = [camera(i, *placed_poses[i], registered[i], groups.get(i)) for i in range(n)]
    pairs, shared = {}, {}
    for i in range(n):
        for j in range(i + 1, n):
            true_gap = np.hypot(*(np.subtract(true_poses[i][:2], true_poses[j][:2])))
            if true_gap > 2.5:
                continue
            placed_gap = np.hypot(*(np.subtract(placed_poses[i][:2], placed_poses[j][:2])))
            key = pair_key(i + 1, j + 1)
            pairs[key] = 150
            if registered[i] and registered[j]:
                shared[key] = 100 if abs(placed_gap - true_gap) < 0.5 else 2
    return TriageInput(TopDownScene(FRAME, cams, np.zeros((0, 2))), pairs, shared)


def straight(n, step=1.0):
    return [(i * step, 0.0, 90.0 + 8 * np.sin(1.3 * i)) for i in range(n)]


def raised(result):
    return {s.image_id - 1 for s in result.suspects if s.score >= RAISE_SCORE}


def test_a_long_jump_breaks_continuity_but_a_sway_does_not():
    walk = straight(6)
    walk[3] = (walk[3][0], 0.0, walk[3][2] + 25)  # a 25 deg sway
    placed = walk[:4] + [(x + 6.0, y, yaw) for x, y, yaw in walk[4:]]
    data = capture(walk, placed)
    steps = signals.steps_between(data.scene.cameras, data.pairs, data.shared_points)
    assert [s.breaks for s in steps] == [False, False, False, True, False]
    assert steps[3].conflict and steps[3].length_steps > 6


@pytest.mark.parametrize(("inliers", "shared", "conflict"),
                         [(100, 5, True), (100, 60, False), (20, 0, False), (30, 4, True)])
def test_a_conflict_is_many_matches_the_model_does_not_share(inliers, shared, conflict):
    assert signals.is_conflict(inliers, shared) is conflict


def test_missing_share_needs_enough_expected_points():
    assert signals.missing_share(MissingCount(10, 0)) is None
    assert signals.missing_share(MissingCount(100, 10)) == pytest.approx(0.9)
    assert signals.missing_share(None) is None


def test_a_run_folded_back_to_the_start_is_raised_and_proposed_where_it_continues():
    walk = straight(12)
    placed = walk[:7] + [(x - 7.0, y + 0.1, yaw) for x, y, yaw in walk[7:]]  # folded onto 0-4
    result = triage(capture(walk, placed))
    assert raised(result) == set(range(7, 12))
    assert max(s.score for s in result.suspects if s.image_id - 1 < 7) < RAISE_SCORE
    (run,) = result.runs
    assert run.image_ids == [8, 9, 10, 11, 12]
    for edit, truth in zip(run.proposal, walk[7:], strict=True):
        assert np.hypot(edit.x - truth[0], edit.y - truth[1]) < 0.6
        assert signals.turn_deg(edit.yaw_deg, truth[2]) < 20


def test_a_right_capture_raises_nothing():
    walk = straight(15)
    result = triage(capture(walk, walk))
    assert raised(result) == set() and result.runs == []


def orbit(n=36, radius=3.0):
    angles = np.radians(np.arange(n) * 360.0 / n)
    return [(radius * np.cos(a), radius * np.sin(a), np.degrees(a) + 180.0) for a in angles]


def test_an_orbit_keeps_the_stretch_across_its_seam_and_turns_the_folded_run_back():
    ring = orbit()
    turn = np.array([0.0, 0.0, np.radians(90.0)])  # a quarter turn about the pillar
    placed = list(ring)
    for i in range(10, 19):
        x, y, yaw = poses2d.compose(turn, poses2d.pose(*ring[i]))
        placed[i] = (x, y, np.degrees(yaw))
    result = triage(capture(ring, placed))
    assert raised(result) == set(range(10, 19))
    (run,) = result.runs
    errors = [np.hypot(e.x - ring[i][0], e.y - ring[i][1])
              for e, i in zip(run.proposal, range(10, 19), strict=True)]
    assert max(errors) < 0.3  # fitted between its two trusted neighbours


def test_cameras_of_another_model_are_only_in_runs_and_placed_after_their_neighbours():
    walk = straight(10)
    registered = [True] * 6 + [False] * 4
    groups = {i: {"x": 40.0 + i, "y": 7.0, "yaw_deg": walk[i][2]} for i in range(6, 10)}
    result = triage(capture(walk, walk, registered, groups))
    assert {s.image_id for s in result.suspects} == set(range(1, 7))
    (run,) = result.runs
    assert run.image_ids == [7, 8, 9, 10] and "model 1" in run.reason
    assert [round(e.x) for e in run.proposal] == [6, 7, 8, 9]


def test_continuing_a_circle_stays_on_it_and_a_rigid_fit_recovers_a_motion():
    a, b = poses2d.pose(3, 0, 90), poses2d.pose(3 * np.cos(0.2), 3 * np.sin(0.2), 90 + np.degrees(0.2))
    after = poses2d.continue_forward(a, b)
    assert np.hypot(*after[:2]) == pytest.approx(3.0)
    assert np.arctan2(after[1], after[0]) == pytest.approx(0.4)
    motion = np.array([1.0, -2.0, 0.7])
    source = np.array([poses2d.pose(0, 0, 0), poses2d.pose(2, 1, 30)])
    assert poses2d.fit_rigid(source, poses2d.apply(motion, source), 1.0) == pytest.approx(motion)


def test_a_model_no_pair_links_to_the_rest_is_proposed_where_the_capture_continues():
    walk = straight(10)
    registered = [True] * 6 + [False] * 4
    groups = {i: {"x": 40.0 + i, "y": 7.0, "yaw_deg": walk[i][2]} for i in range(6, 10)}
    data = capture(walk, walk, registered, groups)
    cut = {k: n for k, n in data.pairs.items() if (k[0] > 6) == (k[1] > 6)}
    (run,) = triage(TriageInput(data.scene, cut, data.shared_points)).runs
    assert run.image_ids == [7, 8, 9, 10] and "no verified pair" not in run.reason
    assert [round(e.x) for e in run.proposal] == [6, 7, 8, 9]


def u_turn():
    """Out along +x facing +y, a turn on the spot (an arc of radius 2, 30 deg a step), back
    along -x facing -y: every step on the arc is the same motion in its camera's frame."""
    out = [(float(i), 0.0, 90.0) for i in range(9)]
    arc = [(9.0 + 2 * np.cos(np.radians(a)), -2.0 + 2 * np.sin(np.radians(a)), a)
           for a in range(90, -91, -30)]
    back = [(8.0 - i, -4.0, -90.0) for i in range(8)]
    return out + arc + back  # 9 + 7 + 8 cameras; the arc is 9-15


@pytest.mark.parametrize("backwards", [False, True])
def test_another_model_is_turned_across_a_gap_the_way_the_capture_turns_at_its_edges(backwards):
    walk = u_turn()
    n = len(walk)
    # by index along the walk out: the largest model ends two steps into the arc (0-11), 12 and
    # 13 are in no model, the other model is 14 on; backwards, the capture walks it in reverse
    order = list(range(n))[::-1] if backwards else list(range(n))
    walk = [walk[o] for o in order]
    registered = [o <= 11 for o in order]
    other = {i for i, o in enumerate(order) if o >= 14}
    moved = np.array([30.0, 7.0, np.radians(137.0)])  # the other model's own frame
    groups = {}
    for i in other:
        x, y, yaw = poses2d.compose(moved, poses2d.pose(*walk[i]))
        groups[i] = {"x": x, "y": y, "yaw_deg": np.degrees(yaw)}
    data = capture(walk, walk, registered, groups)
    cut = {k: v for k, v in data.pairs.items() if (k[0] - 1 in other) == (k[1] - 1 in other)}
    runs = triage(TriageInput(data.scene, cut, data.shared_points)).runs
    loose = {i for i, o in enumerate(order) if o in (12, 13)}
    assert sorted(sorted(r.image_ids) for r in runs) == sorted([sorted(i + 1 for i in other),
                                                                sorted(i + 1 for i in loose)])
    for run in runs:  # the loose cameras on the walk across the gap, the model beyond it
        for edit in run.proposal:
            x, y, yaw = walk[edit.image_id - 1]
            assert np.hypot(edit.x - x, edit.y - y) < 1e-6
            assert signals.turn_deg(edit.yaw_deg, yaw) < 1e-6


def test_a_bridge_walks_on_at_the_mean_of_its_edge_steps_from_either_side():
    ring = [poses2d.pose(*p) for p in orbit(n=24)]
    elsewhere = np.array([-5.0, 2.0, 1.0])
    after = poses2d.apply(elsewhere, np.array(ring[10:14]))
    trail = other_models.bridge(np.array(ring[:7]), after, 3, 1.0)
    assert trail == pytest.approx(np.array(ring[7:11]))
    back = other_models.bridge(np.array(ring[10:14])[::-1], poses2d.apply(elsewhere, ring[:7])[::-1],
                               3, 1.0)
    assert back == pytest.approx(np.array(ring[6:10])[::-1])


def test_true_neighbours_the_model_cannot_hold_break_even_a_short_step():
    walk = [(float(i), 0.0, 90.0) for i in range(12)]
    placed = walk[:7] + [(x + 1.5, y, yaw) for x, y, yaw in walk[7:]]  # 2.5 steps: not long
    data = capture(walk, placed)
    steps = signals.steps_between(data.scene.cameras, data.pairs, data.shared_points)
    assert steps[6].length_steps < signals.BREAK_STEPS and steps[6].conflict and steps[6].breaks
    assert raised(triage(data)) == set(range(7, 12))



def test_a_run_that_jumped_for_real_goes_where_its_look_alike_matches_put_it():
    """The capture jumps to a twin structure 5 m aside and the model folded the jump onto the
    first one: continuing the walk would put the run 5 m off, but the points its matches with
    trusted cameras join, held apart by the model, say where it goes (an eighth of them
    look-alikes of the twin)."""
    rng = np.random.default_rng(5)
    walk = straight(12)
    truth = walk[:7] + [(x, y + 5.0, yaw) for x, y, yaw in walk[7:]]
    placed = walk[:7] + [(x - 7.0, y + 0.1, yaw) for x, y, yaw in walk[7:]]
    move = np.array([7.0, 4.9, 0.0])  # the run's way from placed to true: a pose on the left
    split = {}
    for trusted in range(1, 8):
        for run_camera in range(8, 13):
            held = rng.uniform(-3.0, 3.0, (40, 2)) + [3.0, 6.0]  # the trusted camera's points
            own = symmetry.apply(poses2d.inverse(move), held)  # the run's, where it is placed
            own[::8] = held[::8] - [0.0, 5.0]  # look-alikes: the twin, 5 m aside
            split[pair_key(trusted, run_camera)] = (held, own)
    data = dataclasses.replace(capture(truth, placed), split_points=split)
    look_alike_hop = {(7, 8): np.array([0.5, -4.0, 1.0])}  # a hop never overrides the symmetry
    for hops in ({}, look_alike_hop):
        (run,) = triage(dataclasses.replace(data, hops=hops)).runs
        assert run.image_ids == [8, 9, 10, 11, 12] and "symmetry" in run.reason
        for edit, true in zip(run.proposal, truth[7:], strict=True):
            assert np.hypot(edit.x - true[0], edit.y - true[1]) < 0.3
            assert signals.turn_deg(edit.yaw_deg, true[2]) < 5


def _jump_capture():
    """A walk of 12 whose last 5 cameras jumped for real, 6 m across and turned round (the far
    side of the structure); the model folded them back beside the walk, turned 120 deg."""
    walk = straight(12)
    truth = walk[:7] + [(x - 3.0, y + 6.0, yaw + 180.0) for x, y, yaw in walk[7:]]
    fold = np.array([20.0, -3.0, np.radians(120.0)])  # the model's rigid fold of the run
    run = poses2d.apply(fold, np.array([poses2d.pose(*p) for p in truth[7:]]))
    placed = walk[:7] + [(x, y, np.degrees(yaw)) for x, y, yaw in run]
    return truth, placed


def _hop(truth, start, to):
    """The true 2D pose of camera `to` seen from camera `start` (0-based), keyed by image ids."""
    pose = [poses2d.pose(*p) for p in truth]
    return {(start + 1, to + 1): poses2d.between(pose[start], pose[to])}


def test_a_run_that_jumped_for_real_follows_its_capture_neighbours_hop():
    truth, placed = _jump_capture()
    data = capture(truth, placed)
    (run,) = triage(data).runs
    assert run.image_ids == [8, 9, 10, 11, 12]
    # continuing the walk puts it far off; the neighbours' own geometry across the jump does not
    off = [np.hypot(e.x - t[0], e.y - t[1]) for e, t in zip(run.proposal, truth[7:], strict=True)]
    assert max(off) > 2.0
    (run,) = triage(dataclasses.replace(data, hops=_hop(truth, 6, 7))).runs
    assert "capture neighbour across the break" in run.reason
    for edit, true in zip(run.proposal, truth[7:], strict=True):
        assert np.hypot(edit.x - true[0], edit.y - true[1]) < 0.1
        assert signals.turn_deg(edit.yaw_deg, true[2]) < 1


def test_a_model_between_two_trusted_stretches_is_fitted_to_the_walks_from_both():
    ring = [poses2d.pose(*p) for p in orbit(n=30)]
    cams = [camera(i, 0.0, 0.0, 0.0, registered=not 10 <= i < 20) for i in range(30)]
    moved = poses2d.apply(np.array([12.0, -3.0, 2.0]), np.array(ring[10:20]))
    pieces = [Piece(PLACED, cams[:10], np.array(ring[:10])), Piece(GROUP, cams[10:20], moved),
              Piece(PLACED, cams[20:], np.array(ring[20:]))]
    poses = [p.poses for p in pieces]
    other_models.place_other_models(pieces, poses, [True, False, True], 1.0)
    assert poses[1] == pytest.approx(np.array(ring[10:20]))
    poses = [p.poses for p in pieces]
    other_models.place_other_models(pieces, poses, [True, False, False], 1.0)  # one side only
    assert poses[1] == pytest.approx(np.array(ring[10:20]))


@pytest.mark.parametrize("per_pair", [80, 600])  # 2,800 split points, and 21,000 (thinned to 3,000)
def test_the_symmetry_beats_the_continuation_by_shares_not_by_how_many_points_there_are(per_pair):
    """Half of the split points agree with the true move, a tenth with the continuation: the
    symmetry wins however many points there are (it was counted among the thinned ones, the
    continuation among all of them, so many points made the continuation win)."""
    walk = straight(12)
    truth = walk[:7] + [(x, y + 5.0, yaw) for x, y, yaw in walk[7:]]
    placed = walk[:7] + [(x - 7.0, y + 0.1, yaw) for x, y, yaw in walk[7:]]
    move = np.array([7.0, 4.9, 0.0])
    (plain,) = triage(capture(truth, placed)).runs
    continued = poses2d.fit_rigid(np.array([poses2d.pose(*p) for p in placed[7:]]),
                                  np.array([poses2d.pose(e.x, e.y, e.yaw_deg) for e in plain.proposal]), 2.0)
    rng, split = np.random.default_rng(5), {}
    for trusted in range(1, 8):
        for run_camera in range(8, 13):
            held = rng.uniform(-3.0, 3.0, (per_pair, 2)) + [3.0, 6.0]
            own = rng.uniform(-3.0, 3.0, (per_pair, 2)) + [-4.0, 1.0]  # agreeing with nothing
            half, tenth = per_pair // 2, per_pair * 6 // 10
            own[:half] = symmetry.apply(poses2d.inverse(move), held[:half])
            own[half:tenth] = symmetry.apply(poses2d.inverse(continued), held[half:tenth])
            split[pair_key(trusted, run_camera)] = (held, own)
    (run,) = triage(dataclasses.replace(capture(truth, placed), split_points=split)).runs
    assert "symmetry" in run.reason
