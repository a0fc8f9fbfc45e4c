"""Object layouts: twin objects close together, and an inward-facing orbit around a pillar whose four
sides carry one pattern, so plain COLMAP folds the ring onto a quarter of it."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from guided_sfm.sample import textures as tx
from guided_sfm.sample.geometry import box_quads, horizontal_quad, wall_quad
from guided_sfm.sample.layouts import VGA, WALL_TPM, Layout, poses_along, room
from guided_sfm.sample.raycast import Scene


def plain(rng: np.random.Generator, w: int, h: int, amplitude: float = 0.06) -> np.ndarray:
    """Evenly painted surface: one colour, soft large-scale mottling, next to no corners for SIFT."""
    base = rng.integers(140, 210, 3).astype(np.float32)
    arr = base * (1.0 + amplitude * tx.fbm(rng, h, w, w / 2, 3))[..., None]
    return np.clip(arr, 0, 255).astype(np.uint8)


def plain_room(scene: Scene, rng: np.random.Generator, length: float, width: float, height: float) -> None:
    """Blank walls, floor and ceiling of a length x width x height room with a corner at the origin:
    corners only where the layout hangs pictures or stands objects."""
    wall = scene.add_texture(plain(rng, 400, 140))
    for center, yaw, span in (((length / 2, width, height / 2), -90.0, length),
                              ((length / 2, 0.0, height / 2), 90.0, length),
                              ((0.0, width / 2, height / 2), 0.0, width),
                              ((length, width / 2, height / 2), 180.0, width)):
        scene.quads.append(wall_quad(center, yaw, span, height, wall))
    scene.quads.append(horizontal_quad(0, 0, length, width, 0.0, scene.add_texture(plain(rng, 300, 300))))
    scene.quads.append(horizontal_quad(0, 0, length, width, height, scene.add_texture(plain(rng, 200, 200))))


def facing(center, target) -> float:
    """Yaw (deg, ccw from +x) of the direction from center to target on the ground."""
    return float(np.degrees(np.arctan2(target[1] - center[1], target[0] - center[0])))


def arc(target, radius: float, start_deg: float, stop_deg: float, count: int):
    """(x, y, yaw) of `count` views on a circle around target, each facing it."""
    out = []
    for angle in np.radians(np.linspace(start_deg, stop_deg, count)):
        center = (target[0] + radius * np.cos(angle), target[1] + radius * np.sin(angle))
        out.append((*center, facing(center, target)))
    return out


def twins(seed: int) -> Layout:
    """Two identical boxes 0.6 m apart in an 8 x 6 m room, each circled halfway at 1.4 m."""
    rng = np.random.default_rng([seed, 11])
    scene = Scene()
    room(scene, rng, 8.0, 6.0, 2.8, panel=4.0)
    size = (1.0, 0.8, 1.1)
    side = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[2] * WALL_TPM)))
    top = scene.add_texture(tx.panel(rng, int(size[0] * WALL_TPM), int(size[1] * WALL_TPM)))
    centers = [(3.2, 3.2), (4.8, 3.2)]
    for center in centers:
        scene.quads.extend(box_quads(center, size, -90.0, top, side, flat=True))
    path = (arc(centers[0], 1.4, -160.0, -50.0, 11) + arc(centers[1], 1.4, -130.0, -20.0, 11)
            + arc(centers[1], 1.9, 20.0, 60.0, 4) + arc(centers[0], 1.9, 120.0, 160.0, 4))
    return Layout(scene, VGA, poses_along(path, rng, pitch=-22.0, sway=2.0, eye=1.45))


def orbit(seed: int) -> Layout:
    """A 1.2 m square pillar with one mural on all four sides, circled by 36 inward-facing views
    in a plainly painted 9 x 9 m room."""
    return _orbit(np.random.default_rng([seed, 12]), (1.2, 1.2, 2.4), 2.6, 36)


def orbit_wide(seed: int) -> Layout:
    """orbit around another object at another radius: a 0.8 x 1.6 m pillar (its two broad sides
    alike, its two narrow sides alike) circled by 40 views at 3.3 m."""
    return _orbit(np.random.default_rng([seed, 13]), (1.6, 0.8, 2.2), 3.3, 40)


def _orbit(rng: np.random.Generator, size: tuple[float, float, float], radius: float,
           count: int) -> Layout:
    scene = Scene()
    length = width = 9.0
    height = 3.0
    plain_room(scene, rng, length, width, height)
    scene.lights.extend(np.array([x, y, height - 0.05]) for x in (3.0, 6.0) for y in (3.0, 6.0))
    art = scene.add_texture(tx.mural(rng, int(size[0] * WALL_TPM), int(size[2] * WALL_TPM)))
    middle = (length / 2, width / 2)
    scene.quads.extend(box_quads(middle, size, 0.0, art, art, flat=True))
    path = arc(middle, radius, -90.0, -90.0 + 360.0 * (count - 1) / count, count)
    return Layout(scene, VGA, poses_along(path, rng, pitch=-4.0, sway=0.0, eye=1.5))


OBJECT_LAYOUTS: dict[str, Callable[[int], Layout]] = {"twins": twins, "orbit": orbit,
                                                       "orbit_wide": orbit_wide}
