"""Triage (design.md v1.1): a score in [0, 1] and readable reasons per camera of the largest
model, and runs (capture-order stretches that move as one) with a proposal of where each belongs,
as edit-set cameras in the scene's 2D frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guided_sfm.core.triage import signals
from guided_sfm.core.triage.evidence import TriageInput
from guided_sfm.core.triage.pieces import GROUP, LOOSE, PLACED, Piece, cut_pieces
from guided_sfm.core.triage.placement import Placement, place_pieces
from guided_sfm.core.types import CameraEdit

RAISE_SCORE = 0.5  # the editor raises a suspect from this score on, on every scene
MISSING_HIGH = 0.9  # a camera that matched under a tenth of what others see in its view


@dataclass(frozen=True)
class Suspect:
    image_id: int
    score: float
    reasons: list[str]


@dataclass(frozen=True)
class Run:
    image_ids: list[int]
    reason: str
    proposal: list[CameraEdit] | None


@dataclass(frozen=True)
class Triage:
    suspects: list[Suspect]  # highest score first
    runs: list[Run]

    def to_dict(self, names: dict[int, str] | None = None) -> dict:
        """The contract's document; with names, images by name (the CLI's form)."""
        def ref(image_id: int):
            return names[image_id] if names else image_id

        key, keys = ("name", "names") if names else ("image_id", "image_ids")
        return {
            "suspects": [{key: ref(s.image_id), "score": round(s.score, 3), "reasons": s.reasons}
                         for s in self.suspects],
            "runs": [{keys: [ref(i) for i in r.image_ids], "reason": r.reason,
                      "proposal": None if r.proposal is None else {"cameras": [
                          {key: ref(c.image_id), "x": round(c.x, 4), "y": round(c.y, 4),
                           "yaw_deg": round(c.yaw_deg, 2)} for c in r.proposal]}}
                     for r in self.runs],
        }


def triage(data: TriageInput) -> Triage:
    """Suspects and runs of one reconstruction (see the module docstring)."""
    cameras = _capture_order(data)
    steps = signals.steps_between(cameras, data.pairs, data.shared_points)
    step = signals.typical_step_of(cameras)
    group_poses = {c.image_id: (c.group_pose["x"], c.group_pose["y"], c.group_pose["yaw_deg"])
                   for c in cameras if c.group_pose is not None}
    pieces = cut_pieces(cameras, steps, group_poses)
    placement = place_pieces(pieces, step, data.anchors, data.split_points, data.hops,
                             data.ground_points)
    if placement is None:
        return Triage([], [])
    moved = [i for i, piece in enumerate(pieces) if not placement.trusted[i]]
    share = signals.typical_share(cameras, data.pairs, data.shared_points)
    conflicts = signals.conflicts_by_image(data.pairs, data.shared_points, share)
    suspects = [_judge(c, pieces, placement, i, data, conflicts)
                for i, piece in enumerate(pieces) if piece.kind == PLACED for c in piece.cameras]
    suspects.sort(key=lambda s: (-s.score, s.image_id))
    scores = {s.image_id: s.score for s in suspects}
    runs = [_run(pieces[i], placement.poses[i], pieces[placement.anchor], data.pairs,
                 _how(placement, i)) for i in moved]
    runs.sort(key=lambda r: (-max(scores.get(i, 1.0) for i in r.image_ids), r.image_ids[0]))
    return Triage(suspects, runs)


def _capture_order(data: TriageInput) -> list:
    """The cameras in capture order; a closed loop starts at its first break, so the stretch
    across its seam stays one piece."""
    cameras = sorted(data.scene.cameras, key=lambda c: c.seq)
    if not signals.closes_loop(cameras, data.pairs, data.shared_points):
        return cameras
    start = signals.loop_start(cameras, signals.steps_between(cameras, data.pairs,
                                                                data.shared_points))
    return cameras[start:] + cameras[:start]


_SYMMETRY = "moved by the symmetry their look-alike matches with the placed cameras imply"
_HOP = ("moved where the matches of their capture neighbour across the break put them "
        "(the capture jumps there)")
_CONTINUE = "moved to continue the trajectory of their neighbours"


def _how(placement: Placement, index: int) -> str:
    if placement.by_symmetry[index]:
        return _SYMMETRY
    return _HOP if placement.by_hop and placement.by_hop[index] else _CONTINUE


def _run(piece: Piece, poses: np.ndarray, anchor: Piece, pairs: dict,
         how: str = _CONTINUE) -> Run:
    if piece.kind == LOOSE and not _linked(piece, pairs):
        # no pair at all: a re-map cannot register it wherever it is put
        return Run(piece.image_ids, _run_reason(piece, anchor) + _UNLINKED, None)
    proposal = [CameraEdit(c.image_id, float(p[0]), float(p[1]),
                           float((np.degrees(p[2]) + 180.0) % 360.0 - 180.0))
                for c, p in zip(piece.cameras, poses, strict=True)]
    return Run(piece.image_ids, _run_reason(piece, anchor, how), proposal)


_UNLINKED = "; no verified pair links it to the other cameras, so nothing is proposed"


def _linked(piece: Piece, pairs: dict) -> bool:
    """True when a verified pair joins one of the piece's cameras to a camera outside it."""
    own = set(piece.image_ids)
    return any((a in own) != (b in own) for a, b in pairs)


def _run_reason(piece: Piece, anchor: Piece, how: str = _CONTINUE) -> str:
    if piece.kind == GROUP:
        return (f"{piece.names}: model {piece.cameras[0].model}, apart from the largest; moved as "
                "one piece to continue the capture from its neighbours across the gap")
    if piece.kind == LOOSE:
        return f"{piece.names}: in no model"
    return (f"{piece.names}: {len(piece.cameras)} cameras placed continuously but apart from "
            f"the capture's largest continuous stretch ({anchor.names}); {how} with their own "
            "relative poses")


def _boundary_reasons(piece: Piece) -> tuple[list[str], float, bool]:
    """Reasons from the steps that cut the piece off, the longest of them (typical steps) and
    whether one of them joins true neighbours the model cannot hold."""
    reasons, longest, conflict = [], 0.0, False
    for step in (piece.break_before, piece.break_after):
        if step is None:
            continue
        a, b = step.before.name, step.after.name
        reasons.append(f"{a} -> {b} (capture neighbours) are placed {step.length_steps:.1f} "
                       f"typical steps apart, turning {step.turn_deg:.0f} deg")
        if step.conflict:
            reasons.append(f"{a} and {b} share {step.inliers} verified matches but only "
                           f"{step.shared_points} 3D points in the model")
        longest, conflict = max(longest, step.length_steps), conflict or step.conflict
    return reasons, longest, conflict


def _camera_reasons(camera, data: TriageInput,
                    conflicts_of: dict[int, list]) -> tuple[list[str], bool, bool]:
    """(reasons, has conflicting pairs, misses what others see) of one camera; conflicts_of:
    signals.conflicts_by_image against the capture's typical share."""
    reasons = []
    conflicts = conflicts_of.get(camera.image_id, [])
    if conflicts:
        worst = max(conflicts, key=lambda c: c[1])
        other = data.scene.camera(worst[0][0] if worst[0][1] == camera.image_id else worst[0][1])
        reasons.append(f"{len(conflicts)} verified pair(s) the model cannot hold, e.g. with "
                       f"{other.name}: {worst[1]} matches, {worst[2]} shared 3D points")
    share = signals.missing_share(data.missing.get(camera.image_id))
    missing = share is not None and share >= MISSING_HIGH
    if missing:
        count = data.missing[camera.image_id]
        reasons.append(f"matched {count.matched} of {count.expected} points that cameras from "
                       "elsewhere in the capture, placed here, see in its view")
    return reasons, bool(conflicts), missing


def _judge(camera, pieces: list[Piece], placement: Placement, index: int,
           data: TriageInput, conflicts_of: dict[int, list]) -> Suspect:
    piece, anchor = pieces[index], pieces[placement.anchor]
    own, has_conflicts, missing = _camera_reasons(camera, data, conflicts_of)
    if placement.trusted[index]:
        at_break = camera in (piece.cameras[0], piece.cameras[-1]) and (
            piece.break_before or piece.break_after)
        score = 0.05 + 0.15 * has_conflicts + 0.1 * bool(at_break) + 0.1 * missing
        return Suspect(camera.image_id, score, own)
    reasons, longest, conflict = _boundary_reasons(piece)
    reasons.insert(0, f"in {piece.names} ({len(piece.cameras)} cameras), cut off from the "
                      f"largest continuous stretch {anchor.names} ({len(anchor.cameras)})")
    score = (0.55 + 0.15 * conflict + 0.15 * min(1.0, max(0.0, longest - 3.0) / 5.0)
             + 0.1 * (len(piece.cameras) * 2 <= len(anchor.cameras)) + 0.05 * missing)
    return Suspect(camera.image_id, min(1.0, score), reasons + own)
