"""Sample layouts: rooms with repeated identical objects and a walking camera path."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from guided_sfm.sample import textures as tx
from guided_sfm.sample.geometry import box_quads, horizontal_quad, look, wall_quad
from guided_sfm.sample.raycast import PinholeCamera, Scene

WALL_TPM = 200.0  # texels per metre on walls, murals and posters (5 mm)
FLOOR_TPM = 120.0
EYE = 1.55  # camera height, metres
VGA = PinholeCamera(640, 480, 460.0, 460.0, 320.0, 240.0)
QVGA = PinholeCamera(320, 240, 260.0, 260.0, 160.0, 120.0)


@dataclass
class Layout:
    """A renderable scene, its camera and the capture-ordered cam_from_world poses."""

    scene: Scene
    camera: PinholeCamera
    poses: list[tuple[np.ndarray, np.ndarray]]


def room(
    scene: Scene,
    rng: np.random.Generator,
    length: float,
    width: float,
    height: float,
    panel: float = 3.0,
    floor: str = "wood",
    bricks: tuple[int, ...] = (),
) -> None:
    """Floor, ceiling, lights and four walls of the room [0, length] x [0, width] x [0, height]."""
    wall_px = int(height * WALL_TPM)
    for wall_y, facing in ((width, -90.0), (0.0, 90.0)):
        for i, x0 in enumerate(np.arange(0, length, panel)):
            w = min(panel, length - x0)
            px = int(w * WALL_TPM)
            img = (
                tx.brick(rng, px, wall_px, WALL_TPM)
                if (i, facing) in [(b, -90.0) for b in bricks]
                else tx.plaster(rng, px, wall_px, int(40 * w))
            )
            scene.quads.append(
                wall_quad((x0 + w / 2, wall_y, height / 2), facing, w, height, scene.add_texture(img))
            )
    for x, facing in ((0.0, 0.0), (length, 180.0)):
        img = tx.plaster(rng, int(width * WALL_TPM), wall_px, int(40 * width))
        scene.quads.append(
            wall_quad((x, width / 2, height / 2), facing, width, height, scene.add_texture(img))
        )
    for x0 in np.arange(0, length, panel):
        x1 = min(x0 + panel, length)
        fw, fh = int((x1 - x0) * FLOOR_TPM), int(width * FLOOR_TPM)
        img = tx.wood_floor(rng, fw, fh, FLOOR_TPM) if floor == "wood" else tx.tiles(rng, fw, fh, FLOOR_TPM)
        scene.quads.append(horizontal_quad(x0, 0, x1, width, 0.0, scene.add_texture(img)))
        ceil = tx.tiles(rng, fw // 2, fh // 2, FLOOR_TPM / 2, 0.6)
        scene.quads.append(horizontal_quad(x0, 0, x1, width, height, scene.add_texture(ceil)))
        scene.lights.append(np.array([(x0 + x1) / 2, width / 2, height - 0.05]))


def hang(
    scene: Scene,
    texture: int,
    x: float,
    wall_y: float,
    facing: float,
    size,
    z: float,
    flat: bool = False,
) -> None:
    """Hang a picture centred at (x, z) 1 cm in front of the wall at wall_y."""
    off = 0.01 if facing > 0 else -0.01
    scene.quads.append(wall_quad((x, wall_y + off, z), facing, size[0], size[1], texture, flat))


def _poster(scene: Scene, rng: np.random.Generator, size) -> int:
    return scene.add_texture(tx.poster(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))


def walk(
    keys: list[tuple[float, float, float]], counts: list[int], sways: list[float] | None = None
) -> tuple[list[tuple[float, float, float]], list[float]]:
    """Sample (x, y, yaw) linearly between consecutive keyframes, counts[i] samples per segment.

    Also returns each sample's sway amplitude (deg): sways[i] on segment i (default 1), so a
    turn can be walked steadily while the straight stretches sway.
    """
    sways = [1.0] * len(counts) if sways is None else sways
    out, amplitude = [], []
    for (a, b), n, sway in zip(zip(keys[:-1], keys[1:], strict=True), counts, sways, strict=True):
        for f in np.arange(n) / n:
            out.append(tuple(np.asarray(a) * (1 - f) + np.asarray(b) * f))
            amplitude.append(sway)
    out.append(keys[-1])
    amplitude.append(sways[-1])
    return out, amplitude


def poses_along(
    path, rng: np.random.Generator, pitch: float = -8.0, sway=0.0, eye: float = EYE
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Hand-held poses along a path: small seeded jitter of position, height and angles.

    `sway` (deg) is one amplitude or one per pose.
    """
    sways = np.broadcast_to(np.asarray(sway, dtype=float), (len(path),))
    poses = []
    for i, (x, y, yaw) in enumerate(path):
        jitter = rng.normal(0, 1, 5)
        center = (x + 0.03 * jitter[0], y + 0.03 * jitter[1], eye + 0.03 * jitter[2])
        yaw_i = yaw + sways[i] * np.sin(i * 1.3) + 1.5 * jitter[3]
        poses.append(look(center, yaw_i, pitch + 1.0 * jitter[4]))
    return poses


def murals(seed: int) -> Layout:
    """A 26 m corridor walked out and back past one mural hung twice on each side."""
    rng = np.random.default_rng([seed, 1])
    scene = Scene()
    length, width, height = 26.0, 6.0, 3.0
    room(scene, rng, length, width, height, bricks=(3,))
    size = (2.6, 1.7)
    art = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
    for x in (5.5, 16.5):
        hang(scene, art, x, width, -90.0, size, 1.5, flat=True)
    for x in (6.0, 17.0):
        hang(scene, art, x, 0.0, 90.0, size, 1.5, flat=True)
    _corridor_end(scene, rng, length)
    for x, wall_y, facing in (
        (2.0, width, -90),
        (11.0, width, -90),
        (21.5, width, -90),
        (24.2, width, -90),
        (11.5, 0.0, 90),
        (19.5, 0.0, 90),
        (23.0, 0.0, 90),
        (25.0, 0.0, 90),
    ):
        psize = (0.6, 0.85)
        hang(scene, _poster(scene, rng, psize), x, wall_y, facing, psize, 1.6)
    # out along y = 3.3 facing the left wall, back along y = 2.7 facing the right wall, so no
    # view of the way out shares ground with one of the way back; the turn is walked steadily,
    # along an arc, 13 deg and 0.35 m a step, facing the end wall from 3 m so the floor in front
    # of it stays in view
    keys = [(1.5, 3.3, 90.0), (20.6, 3.3, 90.0), (23.0, 3.0, 0.0), (20.6, 2.7, -90.0)]
    path, sway = walk([*keys, (4.5, 2.7, -90.0)], [23, 7, 7, 19], [12.0, 0.0, 0.0, 12.0])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-12.0, sway=sway))


def _corridor_end(scene: Scene, rng: np.random.Generator, length: float) -> None:
    """The end of the murals corridor, seen all through the turn: a unique painting, notices, a
    cabinet, and a free-standing stand that gives the turn's views depth beyond the end wall."""
    end = (3.0, 1.5)
    board = scene.add_texture(tx.mural(rng, int(end[0] * WALL_TPM), int(end[1] * WALL_TPM)))
    scene.quads.append(wall_quad((length - 0.01, 3.6, 1.55), 180.0, *end, board, flat=True))
    cabinet = [scene.add_texture(tx.panel(rng, 240, 240)) for _ in range(2)]
    scene.quads.extend(box_quads((length - 0.3, 1.0), (1.2, 0.6, 1.1), 180.0, *cabinet, flat=False))
    # a free-standing stand gives the turn's views depth beyond the end wall's plane
    stand = [scene.add_texture(tx.panel(rng, 160, 240)) for _ in range(2)]
    scene.quads.extend(box_quads((length - 1.5, 4.9), (0.5, 0.6, 1.3), 200.0, *stand, flat=False))
    for y in (0.8, 1.6, 5.4):
        psize = (0.6, 0.85)
        scene.quads.append(wall_quad((length - 0.01, y, 1.8), 180.0, *psize, _poster(scene, rng, psize)))


def office(seed: int) -> Layout:
    """An 18 x 7 m office: four identical desks under identical posters, two along each side."""
    rng = np.random.default_rng([seed, 2])
    scene = Scene()
    length, width, height = 18.0, 7.0, 2.8
    room(scene, rng, length, width, height, panel=3.5, floor="tiles")
    top = scene.add_texture(tx.desk_top(rng, int(1.4 * WALL_TPM), int(0.7 * WALL_TPM), WALL_TPM))
    side = scene.add_texture(tx.panel(rng, int(1.4 * WALL_TPM), int(0.75 * WALL_TPM)))
    psize = (0.9, 1.2)
    art = _poster(scene, rng, psize)
    # copies on one side are 9 m apart, so no two nearby views see different copies
    for x, wall_y, facing in ((2.5, width, -90.0), (11.5, width, -90.0), (3.0, 0.0, 90.0), (12.0, 0.0, 90.0)):
        inward = -0.45 if facing < 0 else 0.45
        scene.quads.extend(box_quads((x, wall_y + inward), (1.4, 0.7, 0.75), facing, top, side))
        hang(scene, art, x, wall_y, facing, psize, 1.75, flat=True)
    for x, wall_y, facing in ((7.0, width, -90), (7.5, 0.0, 90), (15.5, width, -90), (16.0, 0.0, 90)):
        usize = (0.7, 1.0)
        hang(scene, _poster(scene, rng, usize), x, wall_y, facing, usize, 1.6)
    # the far end, faced through the turn: a unique whiteboard, notices and a cupboard
    board_size = (2.4, 1.2)
    board = scene.add_texture(tx.mural(rng, int(board_size[0] * WALL_TPM), int(board_size[1] * WALL_TPM)))
    scene.quads.append(wall_quad((length - 0.01, 3.0, 1.5), 180.0, *board_size, board, flat=True))
    for y in (1.2, 4.6):
        nsize = (0.6, 0.85)
        scene.quads.append(wall_quad((length - 0.01, y, 1.6), 180.0, *nsize, _poster(scene, rng, nsize)))
    cupboard = [scene.add_texture(tx.panel(rng, 240, 240)) for _ in range(2)]
    scene.quads.extend(box_quads((length - 0.3, 5.6), (1.0, 0.6, 1.2), 180.0, *cupboard, flat=False))
    # a free-standing filing cabinet gives the turn's views depth beyond the end wall's plane
    filing = [scene.add_texture(tx.panel(rng, 160, 240)) for _ in range(2)]
    scene.quads.extend(box_quads((length - 1.4, 1.5), (0.5, 0.6, 1.3), 160.0, *filing, flat=False))
    # out along y = 4.3 facing the left desks, back along y = 2.7 facing the right ones; the turn
    # is walked steadily, 13 deg and 0.36 m a step, facing the end wall from 2.8 m. Legs 0.6 m
    # apart let a re-registered leg bend nearly for free (docs/pruning-rule.md, "Office re-laid").
    keys = [(1.0, 4.3, 90.0), (12.8, 4.3, 90.0), (15.2, 3.5, 0.0), (12.8, 2.7, -90.0)]
    path, sway = walk([*keys, (1.5, 2.7, -90.0)], [17, 7, 7, 16], [8.0, 0.0, 0.0, 8.0])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-10.0, sway=sway))


def tiny(seed: int) -> Layout:
    """An 8 m corridor with one poster hung twice far apart; 12 small images."""
    rng = np.random.default_rng([seed, 3])
    scene = Scene()
    room(scene, rng, 8.0, 3.0, 2.6, panel=2.0)
    psize = (0.8, 1.0)
    art = scene.add_texture(tx.mural(rng, int(psize[0] * WALL_TPM), int(psize[1] * WALL_TPM)))
    for x in (1.5, 6.5):
        hang(scene, art, x, 3.0, -90.0, psize, 1.5, flat=True)
    path, _ = walk([(1.0, 0.8, 90.0), (7.0, 0.8, 90.0)], [11])
    return Layout(scene, QVGA, poses_along(path, rng, pitch=-18.0, sway=8.0))


LAYOUT_BUILDERS: dict[str, Callable[[int], Layout]] = {
    "murals": murals,
    "office": office,
    "tiny": tiny,
}
