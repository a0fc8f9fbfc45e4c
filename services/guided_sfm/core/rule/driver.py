"""Run an edit set's rule: the pairs it deletes, each with the tests that removed it
(docs/pruning-rule.md). The paper's rule is the frustum test alone (Algorithm 1, design.md); the
default rule judges each pair by its own matches where it has evidence. The edit set comes
checked (core.edits.parse_edits).

A test removes a pair (its verdict); the round deletes the removed pairs and the manual deletions
from the matching database, except the pairs kept to connect.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from itertools import chain

import numpy as np

from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.match_graph import components
from guided_sfm.core.rule.evidence import Evidence, flat_matches
from guided_sfm.core.rule.frustum import PlacedFrustum, frustum_test, placed_frusta
from guided_sfm.core.rule.match_placement import placement_test
from guided_sfm.core.rule.motion import motions_of
from guided_sfm.core.rule.relative_pose import relative_pose_test
from guided_sfm.core.rule.relative_rotation import rotation_test
from guided_sfm.core.rule.separates import SEPARATES, separating_pairs
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.types import (
    DEFAULT_RULE,
    PAPER_RULE,
    CameraEdit,
    EditSet,
    PairKey,
    PruneResult,
    TopDownScene,
    pair_key,
)

# The reasons a pair is deleted (REST `reasons`, `removed_by_test`): the tests, and the user.
FRUSTUM = "frustum"
PLACEMENT = "placement"  # the match-placement test
ROTATION = "rotation"
RELATIVE_POSE = "relative_pose"
MANUAL = "manual"

Removals = dict[str, np.ndarray]  # test -> mask over the tested pairs it removed


def _manual_pairs(edits: EditSet, pairs: Mapping[PairKey, int]) -> list[PairKey]:
    """The manual deletions as canonical keys; each must be a verified pair of this version (the
    parser knows the images, not the pairs)."""
    keys = []
    for a, b in edits.delete_pairs:
        key = pair_key(a, b)
        if key not in pairs:
            raise InvalidInput(f"manual deletion ({a}, {b}) is not a verified pair")
        keys.append(key)
    return keys


def tested_pairs(pairs: Mapping[PairKey, int], placements: Mapping[int, CameraEdit],
                 frusta: Mapping[int, PlacedFrustum]) -> np.ndarray:
    """(P, 2) pairs, sorted, with at least one moved member and both members with a placed pose."""
    flat = np.fromiter(chain.from_iterable(pairs), dtype=np.int64, count=2 * len(pairs))
    keys = np.sort(flat.reshape(-1, 2), axis=1)
    moved_ids = np.fromiter(placements, dtype=np.int64, count=len(placements))
    posed_ids = np.fromiter(frusta, dtype=np.int64, count=len(frusta))
    moved = np.isin(keys, moved_ids).any(axis=1)
    posed = np.isin(keys, posed_ids).all(axis=1)
    tested = keys[moved & posed]
    return tested[np.lexsort((tested[:, 1], tested[:, 0]))]


@dataclass(frozen=True)
class RuleInput:
    """What a rule decides on: the tested pairs, every placed frustum, and the default rule's extras."""

    tested: np.ndarray  # (P, 2) sorted pairs with a moved member, both members with a placed pose
    frusta: Mapping[int, PlacedFrustum]
    scene: TopDownScene
    placements: Mapping[int, CameraEdit]
    tolerances: Tolerances
    evidence: Evidence | None


def _paper_rule(rule_input: RuleInput) -> Removals:
    return {FRUSTUM: frustum_test(rule_input.tested, rule_input.frusta)}


def _default_rule(rule_input: RuleInput) -> Removals:
    """Match placement, relative pose and relative rotation where the pair has evidence, else the
    frustum."""
    tested, evidence = rule_input.tested, rule_input.evidence
    if evidence is None:
        return _paper_rule(rule_input)
    if not evidence.rows:  # no tested camera is in the model (e.g. all in a smaller one)
        nothing = np.zeros(len(tested), dtype=bool)
        return {**_paper_rule(rule_input), PLACEMENT: nothing, RELATIVE_POSE: nothing,
                ROTATION: nothing}
    flat = flat_matches(evidence, tested)
    motions = motions_of(rule_input.scene, rule_input.placements, evidence)
    tolerances = rule_input.tolerances
    placement = placement_test(flat, motions, evidence, tolerances)
    relative_pose = relative_pose_test(flat, motions, evidence, tolerances)
    # Matches that agree with the model, and placements that keep the pair's relative pose within
    # the user's uncertainty: the carried angle then measures the placement error, not the pair.
    placement.removed[relative_pose.judged & ~relative_pose.removed] = False
    rotation = rotation_test(flat, motions, evidence, tolerances,
                             placement.removed | relative_pose.removed)
    frustum = np.zeros(len(tested), dtype=bool)
    frustum[~placement.judged] = frustum_test(tested[~placement.judged], rule_input.frusta)
    return {FRUSTUM: frustum, PLACEMENT: placement.removed, RELATIVE_POSE: relative_pose.removed,
            ROTATION: rotation.removed}


RULE_TESTS: dict[str, Callable[[RuleInput], Removals]] = {
    PAPER_RULE: _paper_rule,
    DEFAULT_RULE: _default_rule,
}


def prune_pairs(scene: TopDownScene, edits: EditSet, pairs: Mapping[PairKey, int],
                evidence: Evidence | None = None) -> PruneResult:
    """Pairs (COLMAP image ids) the edit set's rule deletes, each with the tests that removed it.

    Without evidence (see rule.evidence) the default rule can only run the frustum test.
    """
    tolerances = Tolerances(**edits.tolerances)
    placements = {placement.image_id: placement for placement in edits.cameras}
    manual = _manual_pairs(edits, pairs)
    frusta = placed_frusta(scene, placements, tolerances.range_scale)
    tested = tested_pairs(pairs, placements, frusta)
    reasons: dict[PairKey, tuple[str, ...]] = {}
    removals = RULE_TESTS[edits.rule](RuleInput(tested, frusta, scene, placements, tolerances,
                                                evidence))
    for test, removed in removals.items():
        _add_reason(reasons, zip(*tested[removed].T.tolist(), strict=True), test)
    if edits.rule == DEFAULT_RULE and evidence is not None and evidence.rows:
        separated = RuleInput(separating_pairs(pairs, tested, _any(removals, len(tested)),
                                               set(placements), manual),
                              frusta, scene, placements, tolerances, evidence)
        for key, tests in _separates_removals(separated).items():
            reasons[key] = (SEPARATES, *tests)
    kept = kept_to_connect(pairs, reasons, manual)  # (the paper's rule has no placement test)
    for key in kept:
        del reasons[key]
    _add_reason(reasons, dict.fromkeys(manual), MANUAL)
    return PruneResult(deleted=sorted(reasons), reasons=reasons, kept_to_connect=kept)


def _any(removals: Removals, count: int) -> np.ndarray:
    return np.logical_or.reduce([*removals.values(), np.zeros(count, dtype=bool)])


def _separates_removals(separated: RuleInput) -> dict[PairKey, tuple[str, ...]]:
    """The pairs between unmoved cameras (rule.separates) that the default rule's evidence tests
    remove at their model poses, each with those tests; the frustum test has no say here."""
    if len(separated.tested) == 0:
        return {}
    removals = _default_rule(separated)
    removals.pop(FRUSTUM, None)
    found: dict[PairKey, tuple[str, ...]] = {}
    for test, removed in removals.items():
        for a, b in separated.tested[removed].tolist():
            found[(a, b)] = found.get((a, b), ()) + (test,)
    return found


def kept_to_connect(pairs: Mapping[PairKey, int], reasons: Mapping[PairKey, tuple[str, ...]],
                    manual: list[PairKey]) -> list[PairKey]:
    """Removed pairs to keep so that the match-placement test alone never cuts a group of images
    off the rest of the match graph.

    Kept: the pairs that test alone removed (not the relative-pose test, not the rotation test's
    epipolar stage, not the user by hand; on its own or for `separates`) and that join two parts
    the removals separated. Its angle measures the user's placement error as much as the pair;
    with no link left, a group of cameras cannot be registered at all, let alone where the user
    put it. All such pairs are kept: one alone registers a group poorly.
    """
    manual_keys = set(manual)
    after = {image_id: index
             for index, group in enumerate(components(pairs, set(reasons) | manual_keys))
             for image_id in group}
    return sorted(key for key, tests in reasons.items()
                  if tests in ((PLACEMENT,), (SEPARATES, PLACEMENT)) and key not in manual_keys
                  and after[key[0]] != after[key[1]])


def _add_reason(reasons: dict[PairKey, tuple[str, ...]], keys, test: str) -> None:
    if not reasons:
        reasons.update(dict.fromkeys(keys, (test,)))
        return
    for key in keys:
        reasons[key] = reasons.get(key, ()) + (test,)
