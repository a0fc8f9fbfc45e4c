"""A capture COLMAP splits into two models: a walk out along one wall of a plainly painted hall and
back along the other, turning in place at the far end in front of a blank end wall, so nothing
links the two legs (design.md v1.1 split models; issue 21)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from guided_sfm.sample import textures as tx
from guided_sfm.sample.layouts import VGA, WALL_TPM, Layout, hang, poses_along, walk
from guided_sfm.sample.objects import plain_room
from guided_sfm.sample.raycast import Scene

LENGTH, WIDTH, HEIGHT = 14.0, 6.0, 3.0


def _plain_hall(scene: Scene, rng: np.random.Generator) -> None:
    """Blank walls, floor and ceiling: corners only where pictures hang."""
    plain_room(scene, rng, LENGTH, WIDTH, HEIGHT)
    scene.lights.extend(np.array([x, WIDTH / 2, HEIGHT - 0.05]) for x in (3.0, 7.0, 11.0))


def split(seed: int) -> Layout:
    """Out facing the left wall's murals, a turn in place facing the blank end wall, back facing
    the right wall's (other) murals: two legs that share no picture."""
    rng = np.random.default_rng([seed, 31])
    scene = Scene()
    _plain_hall(scene, rng)
    size = (1.6, 1.1)
    for x in np.arange(1.5, LENGTH - 2.0, 2.2):
        art = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
        hang(scene, art, float(x), WIDTH, -90.0, size, 1.6, flat=True)
        # murals on the right wall too: a wall of posters alone mapped as a bent, 1-4 m off model
        other = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
        hang(scene, other, float(x) + 0.8, 0.0, 90.0, size, 1.6, flat=True)
    turn_x = LENGTH - 3.0
    # each leg bends at its middle, so the cameras of one model are not on one line (a line
    # leaves the roll about it free when a model is aligned to the truth on its centres)
    keys = [(1.5, 3.6, 90.0), (6.5, 3.0, 90.0), (turn_x, 3.5, 90.0), (turn_x + 0.3, 3.1, 0.0),
            (turn_x, 2.7, -90.0), (6.5, 2.2, -90.0), (1.5, 2.7, -90.0)]
    path, sway = walk(keys, [8, 8, 3, 3, 8, 8], [6.0, 6.0, 0.0, 0.0, 6.0, 6.0])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-3.0, sway=sway))


SPLIT_LAYOUTS: dict[str, Callable[[int], Layout]] = {"split": split}
