"""Edit sets as JSON: the one parser of a body (the CLI's file, a REST request, a job's payload),
which checks every value and names the field at fault, and the writer back to JSON."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from guided_sfm.core.errors import InvalidFrustum, InvalidInput, UnknownImage
from guided_sfm.core.rule.tolerances import resolve
from guided_sfm.core.types import DEFAULT_RULE, RULES, CameraEdit, EditSet, pair_key


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InvalidInput(f"{what} must be a finite number, got {value!r}")
    return float(value)


def _check_frustum(fov_deg: float | None, range_: float | None, what: str) -> None:
    """Reject a field of view outside (0, 180) deg or a range that is not positive."""
    if fov_deg is not None and not 0 < fov_deg < 180:
        raise InvalidFrustum(f"{what}: fov_deg must be in (0, 180), got {fov_deg}")
    if range_ is not None and not range_ > 0:
        raise InvalidFrustum(f"{what}: range must be > 0, got {range_}")


def _image_id(ref: Mapping[str, Any] | Any, ids: Mapping[str, int], known: set[int]) -> int:
    """An image given by COLMAP id, by name, or as an object with image_id or name."""
    if isinstance(ref, Mapping):
        ref = ref["image_id"] if "image_id" in ref else ref.get("name")
    if isinstance(ref, str):
        if ref not in ids:
            raise UnknownImage(f"unknown image name {ref!r}")
        return ids[ref]
    if isinstance(ref, bool) or not isinstance(ref, int):
        raise InvalidInput(f"an image must be given by image_id or name, got {ref!r}")
    if ref not in known:
        raise UnknownImage(f"unknown image id {ref}")
    return ref


def _camera(item: Any, ids: Mapping[str, int], known: set[int]) -> CameraEdit:
    if not isinstance(item, Mapping):
        raise InvalidInput(f"each camera must be an object, got {item!r}")
    image_id = _image_id(item, ids, known)
    what = f"camera {item.get('name', image_id)}"
    try:
        x, y, yaw = (_number(item[k], f"{what}: {k}") for k in ("x", "y", "yaw_deg"))
    except KeyError as exc:
        raise InvalidInput(f"{what}: missing field {exc.args[0]}") from exc
    fov = None if item.get("fov_deg") is None else _number(item["fov_deg"], f"{what}: fov_deg")
    range_ = None if item.get("range") is None else _number(item["range"], f"{what}: range")
    _check_frustum(fov, range_, what)
    return CameraEdit(image_id, x, y, yaw, fov, range_)


def parse_edits(body: Any, ids: Mapping[str, int]) -> EditSet:
    """The EditSet of a body, every value checked; images by id or name (ids maps name -> id,
    its ids are the known images). Raises InvalidInput (or UnknownImage) naming the problem."""
    if not isinstance(body, Mapping):
        raise InvalidInput("the edit set must be a JSON object")
    known = set(ids.values())
    cameras = [_camera(item, ids, known) for item in body.get("cameras") or []]
    if len({c.image_id for c in cameras}) != len(cameras):
        raise InvalidInput("a camera appears twice in the edit set")
    pairs = []
    for item in body.get("delete_pairs") or []:
        if not isinstance(item, list | tuple) or len(item) != 2:
            raise InvalidInput(f"each delete_pairs entry must be two images, got {item!r}")
        a, b = (_image_id(ref, ids, known) for ref in item)
        if a == b:
            raise InvalidInput(f"a pair needs two different images, got {item!r}")
        pairs.append(pair_key(a, b))
    rule = body.get("rule") or DEFAULT_RULE
    if rule not in RULES:
        raise InvalidInput(f"unknown rule {rule!r}; choose one of {RULES}")
    tolerances = body.get("tolerances") or {}
    if not isinstance(tolerances, Mapping):
        raise InvalidInput("tolerances must be an object of numbers")
    resolve(tolerances)  # names each bad one
    return EditSet(cameras, sorted(set(pairs)), rule, {str(k): float(v) for k, v in tolerances.items()})


def edits_to_json(edits: EditSet) -> dict[str, Any]:
    """The edit set as a JSON body with COLMAP image ids."""
    return {
        "cameras": [dict(c.__dict__) for c in edits.cameras],
        "delete_pairs": [list(p) for p in edits.delete_pairs],
        "rule": edits.rule,
        "tolerances": dict(edits.tolerances),
    }
