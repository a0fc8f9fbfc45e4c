"""Hall layouts for matching at scale: identical bays along a long hall, walked as one outward-
looking loop. `hall` (55 views) is small enough for a test; `hall-120`, `hall-300`,
`hall-600` and `hall-1000` (595 and 995 views) are the benchmark's larger captures of the same
design."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from guided_sfm.sample import textures as tx
from guided_sfm.sample.geometry import wall_quad
from guided_sfm.sample.layouts import VGA, WALL_TPM, Layout, hang, poses_along, room, walk
from guided_sfm.sample.raycast import Scene

BAY = 4.0  # metres of wall per bay
WIDTH, HEIGHT = 6.0, 3.0
VIEWS_PER_BAY = 10  # per leg: 0.4 m a step
TURN_VIEWS = 7


def _bays(scene: Scene, rng: np.random.Generator, bays: int) -> None:
    """One mural repeated in every bay of the left wall, one poster in every bay of the right,
    and a unique notice per bay at a varying height and offset (what tells the bays apart)."""
    size, psize, nsize = (2.2, 1.5), (1.0, 1.3), (0.5, 0.7)
    mural = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
    poster = scene.add_texture(tx.poster(rng, int(psize[0] * WALL_TPM), int(psize[1] * WALL_TPM)))
    for bay in range(bays):
        x = BAY * bay + BAY / 2
        hang(scene, mural, x, WIDTH, -90.0, size, 1.5, flat=True)
        hang(scene, poster, x + 0.3, 0.0, 90.0, psize, 1.6, flat=True)
        notice = scene.add_texture(tx.poster(rng, int(nsize[0] * WALL_TPM), int(nsize[1] * WALL_TPM)))
        wall_y, facing = (WIDTH, -90.0) if bay % 2 else (0.0, 90.0)
        hang(scene, notice, x + rng.uniform(1.3, 1.6) * (1 if bay % 2 else -1), wall_y, facing,
             nsize, rng.uniform(1.2, 2.0))


def _ends(scene: Scene, rng: np.random.Generator, length: float) -> None:
    """A unique mural on each end wall: the loop's two turns face them."""
    end = (3.0, 1.5)
    for x, facing in ((length - 0.01, 180.0), (0.01, 0.0)):
        art = scene.add_texture(tx.mural(rng, int(end[0] * WALL_TPM), int(end[1] * WALL_TPM)))
        scene.quads.append(wall_quad((x, WIDTH / 2, 1.55), facing, *end, art, flat=True))


def hall(seed: int, bays: int = 2) -> Layout:
    """A hall of `bays` identical 4 m bays, walked out facing the left wall, back facing the
    right one, turning at both ends; the last views look again at the first ones' wall."""
    rng = np.random.default_rng([seed, 22, bays])
    scene = Scene()
    length = BAY * bays + 2.0
    room(scene, rng, length, WIDTH, HEIGHT, panel=BAY)
    _bays(scene, rng, bays)
    _ends(scene, rng, length)
    out, back = WIDTH / 2 + 0.3, WIDTH / 2 - 0.3
    keys = [(1.0, out, 90.0), (length - 3.0, out, 90.0), (length - 3.0, WIDTH / 2, 0.0),
            (length - 3.0, back, -90.0), (1.0, back, -90.0), (1.0, WIDTH / 2, -180.0),
            (1.2, out, -270.0)]
    leg, half = VIEWS_PER_BAY * bays, TURN_VIEWS // 2
    path, sway = walk(keys, [leg, half, TURN_VIEWS - half, leg, half, TURN_VIEWS - half],
                      [8.0, 0.0, 0.0, 8.0, 0.0, 0.0])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-10.0, sway=sway))


HALL_LAYOUTS: dict[str, Callable[[int], Layout]] = {
    "hall": hall,
    "hall-120": partial(hall, bays=5),
    "hall-300": partial(hall, bays=14),
    "hall-600": partial(hall, bays=29),
    "hall-1000": partial(hall, bays=49),
}
