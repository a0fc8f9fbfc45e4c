"""The `separates` reason (design.md, Algorithm 1): the default rule may judge a pair that no moved
camera touches, but only one that joins two groups the placement separates.

The placement says which cameras a moved camera goes with: those its kept pairs join, and which
it does not: those its deleted pairs joined. A pair between two unmoved cameras u and v joins
groups the placement separates when some moved camera goes with u but not with v. Between twin
objects that is a look-alike pair between a camera of each twin, which can pull the moved cameras
back onto the fold in the re-map. Such a pair is judged by the default rule's tests at the two
cameras' model poses (both unmoved); the frustum gives no verdict here, since the placement says
nothing about where two unmoved cameras look.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from guided_sfm.core.types import PairKey

SEPARATES = "separates"


def _sides(tested: np.ndarray, removed: np.ndarray, moved: set[int],
           manual: Iterable[PairKey]) -> tuple[dict[int, set[int]], dict[int, set[int]]]:
    """Per unmoved camera: the moved cameras it goes with (a kept pair) and those it does not
    (a pair the rule removed or the user deleted)."""
    together: dict[int, set[int]] = {}
    apart: dict[int, set[int]] = {}
    links = [(a, b, out) for (a, b), out in zip(tested.tolist(), removed.tolist(), strict=True)]
    links += [(a, b, True) for a, b in manual]
    for a, b, out in links:
        for mover, other in ((a, b), (b, a)):
            if mover in moved and other not in moved:
                (apart if out else together).setdefault(other, set()).add(mover)
    return together, apart


def separating_pairs(pairs: Iterable[PairKey], tested: np.ndarray, removed: np.ndarray,
                     moved: set[int], manual: Iterable[PairKey] = ()) -> np.ndarray:
    """(Q, 2) sorted pairs of two unmoved cameras that join groups the placement separates."""
    together, apart = _sides(tested, removed, moved, manual)
    empty: set[int] = set()
    found = sorted(
        (a, b) for a, b in pairs if a not in moved and b not in moved
        and (together.get(a, empty) & apart.get(b, empty)
             or apart.get(a, empty) & together.get(b, empty)))
    return np.array(found, dtype=np.int64).reshape(-1, 2)


def partners_of_moved(pairs: Iterable[PairKey], moved: set[int]) -> list[PairKey]:
    """The pairs whose evidence the default rule may need: those touching a moved camera, and
    those between two of their unmoved partners (the candidates of `separating_pairs`)."""
    pairs = list(pairs)
    partners = {i for pair in pairs if pair[0] in moved or pair[1] in moved for i in pair}
    return [pair for pair in pairs if pair[0] in moved or pair[1] in moved
            or (pair[0] in partners and pair[1] in partners)]

