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


def walk(keys: list[tuple[float, float, float]], counts: list[int]) -> list[tuple[float, float, float]]:
    """Sample (x, y, yaw) linearly between consecutive keyframes, counts[i] samples per segment."""
    out = []
    for (a, b), n in zip(zip(keys[:-1], keys[1:], strict=True), counts, strict=True):
        for f in np.arange(n) / n:
            out.append(tuple(np.asarray(a) * (1 - f) + np.asarray(b) * f))
    out.append(keys[-1])
    return out


def poses_along(
    path, rng: np.random.Generator, pitch: float = -8.0, sway: float = 0.0, eye: float = EYE
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Hand-held poses along a path: small seeded jitter of position, height and angles."""
    poses = []
    for i, (x, y, yaw) in enumerate(path):
        jitter = rng.normal(0, 1, 5)
        center = (x + 0.03 * jitter[0], y + 0.03 * jitter[1], eye + 0.03 * jitter[2])
        yaw_i = yaw + sway * np.sin(i * 1.3) + 1.5 * jitter[3]
        poses.append(look(center, yaw_i, pitch + 1.0 * jitter[4]))
    return poses


def murals(seed: int) -> Layout:
    """A 26 m corridor walked out and back; one mural twice on the left, once on the right."""
    rng = np.random.default_rng([seed, 1])
    scene = Scene()
    length, width, height = 26.0, 5.0, 3.0
    room(scene, rng, length, width, height, bricks=(3, 7))
    size = (2.6, 1.7)
    art = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
    for x in (5.5, 16.5):
        hang(scene, art, x, width, -90.0, size, 1.5, flat=True)
    hang(scene, art, 15.5, 0.0, 90.0, size, 1.5, flat=True)
    cabinet = [scene.add_texture(tx.panel(rng, 240, 240)) for _ in range(2)]
    scene.quads.extend(box_quads((length - 0.3, 1.2), (1.2, 0.6, 1.1), 180.0, *cabinet, flat=False))
    for y in (2.6, 4.0):
        scene.quads.append(
            wall_quad((length - 0.01, y, 1.7), 180.0, 0.6, 0.85, _poster(scene, rng, (0.6, 0.85)))
        )
    for x, wall_y, facing in (
        (2.0, width, -90),
        (11.0, width, -90),
        (21.5, width, -90),
        (12.0, 0.0, 90),
        (19.5, 0.0, 90),
        (23.0, 0.0, 90),
    ):
        psize = (0.6, 0.85)
        hang(scene, _poster(scene, rng, psize), x, wall_y, facing, psize, 1.6)
    # the turn faces the near end wall, so the way out and the way back share unique texture
    keys = [(1.5, 2.0, 90.0), (21.0, 2.0, 90.0), (22.5, 2.3, 0.0), (22.0, 3.0, -90.0)]
    path = walk([*keys, (12.5, 3.0, -90.0)], [23, 6, 6, 12])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-12.0, sway=12.0))


def office(seed: int) -> Layout:
    """A 14 x 7 m office: four identical desks under identical posters, walked past twice."""
    rng = np.random.default_rng([seed, 2])
    scene = Scene()
    length, width, height = 14.0, 7.0, 2.8
    room(scene, rng, length, width, height, panel=3.5, floor="tiles")
    top = scene.add_texture(tx.desk_top(rng, int(1.4 * WALL_TPM), int(0.7 * WALL_TPM), WALL_TPM))
    side = scene.add_texture(tx.panel(rng, int(1.4 * WALL_TPM), int(0.75 * WALL_TPM)))
    psize = (0.9, 1.2)
    art = _poster(scene, rng, psize)
    for x in (2.0, 5.5, 9.0, 12.5):
        scene.quads.extend(box_quads((x, width - 0.45), (1.4, 0.7, 0.75), -90.0, top, side))
        hang(scene, art, x, width, -90.0, psize, 1.75, flat=True)
    for x in (3.5, 7.0, 10.5):
        usize = (0.7, 1.0)
        hang(scene, _poster(scene, rng, usize), x, 0.0, 90.0, usize, 1.6)
    keys = [(1.0, 3.2, 80.0), (11.0, 3.2, 100.0), (12.0, 3.5, 0.0), (11.0, 3.8, -90.0)]
    path = walk([*keys, (1.0, 3.8, -90.0)], [23, 5, 5, 14])
    return Layout(scene, VGA, poses_along(path, rng, pitch=-14.0, sway=15.0))


def tiny(seed: int) -> Layout:
    """An 8 m corridor with one poster hung twice far apart; 12 small images."""
    rng = np.random.default_rng([seed, 3])
    scene = Scene()
    room(scene, rng, 8.0, 3.0, 2.6, panel=2.0)
    psize = (0.8, 1.0)
    art = scene.add_texture(tx.mural(rng, int(psize[0] * WALL_TPM), int(psize[1] * WALL_TPM)))
    for x in (1.5, 6.5):
        hang(scene, art, x, 3.0, -90.0, psize, 1.5, flat=True)
    path = walk([(1.0, 0.8, 90.0), (7.0, 0.8, 90.0)], [11])
    return Layout(scene, QVGA, poses_along(path, rng, pitch=-18.0, sway=8.0))


LAYOUT_BUILDERS: dict[str, Callable[[int], Layout]] = {
    "murals": murals,
    "office": office,
    "tiny": tiny,
}
