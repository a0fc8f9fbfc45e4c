"""A vectorised ray caster over textured planar quads: nearest hit, mip-mapped lookup, shading."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

NEAR = 0.05  # metres; nothing in the scenes is closer to a camera


@dataclass(frozen=True)
class PinholeCamera:
    """COLMAP PINHOLE intrinsics; pixel (0, 0) is the top-left corner of the first pixel."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def to_dict(self) -> dict[str, object]:
        return {"model": "PINHOLE", **self.__dict__}

    def scaled(self, width: int, height: int) -> PinholeCamera:
        """The same camera at another resolution: the same field of view, every intrinsic scaled
        (exact with the top-left corner convention). The aspect ratio must stay, or the pixels
        would no longer be square."""
        if width < 1 or height < 1 or width * self.height != height * self.width:
            raise ValueError(f"{width}x{height} does not keep the {self.width}x{self.height} "
                             "camera's aspect ratio")
        s = width / self.width
        return PinholeCamera(width, height, self.fx * s, self.fy * s, self.cx * s, self.cy * s)


@dataclass(frozen=True)
class Quad:
    """A textured parallelogram origin + s*u + t*v, s, t in [0, 1]; texture column ~ s, row ~ t."""

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    texture: int
    flat: bool = False  # evenly lit, so identical copies look identical wherever they are

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.u, self.v)
        return n / np.linalg.norm(n)

    def corners(self) -> np.ndarray:
        o, u, v = self.origin, self.u, self.v
        return np.stack([o, o + u, o + u + v, o + v])


class Texture:
    """A uint8 RGB image with its box-filtered mip pyramid."""

    def __init__(self, image: np.ndarray):
        self.levels = [np.ascontiguousarray(image, dtype=np.uint8)]
        while min(self.levels[-1].shape[:2]) >= 8:
            a = self.levels[-1].astype(np.float32)
            h, w = a.shape[0] // 2 * 2, a.shape[1] // 2 * 2
            a = (a[0:h:2, 0:w:2] + a[1:h:2, 0:w:2] + a[0:h:2, 1:w:2] + a[1:h:2, 1:w:2]) / 4
            self.levels.append((a + 0.5).astype(np.uint8))

    def sample(self, level: int, s: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Bilinear lookup of (N,) coordinates in [0, 1] at one mip level; (N, 3) in [0, 1]."""
        img = self.levels[level]
        h, w = img.shape[:2]
        x = np.clip(s * w - 0.5, 0, w - 1.001)
        y = np.clip(t * h - 0.5, 0, h - 1.001)
        x0, y0 = x.astype(np.int64), y.astype(np.int64)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
        bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
        return (top * (1 - fy) + bottom * fy) * (1 / 255)


@dataclass
class Scene:
    """Quads, their textures and the room's point lights (world coordinates, metres, z up)."""

    quads: list[Quad] = field(default_factory=list)
    textures: list[Texture] = field(default_factory=list)
    lights: list[np.ndarray] = field(default_factory=list)
    ambient: float = 0.4

    def add_texture(self, image: np.ndarray) -> int:
        """Register a texture; returns its index for Quad.texture."""
        self.textures.append(Texture(image))
        return len(self.textures) - 1


def _pixel_box(quad: Quad, r: np.ndarray, t: np.ndarray, cam: PinholeCamera):
    """Pixel rows/cols a quad can cover: its polygon clipped at the near plane, projected."""
    pts = quad.corners() @ r.T + t
    kept = []
    for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True):
        if a[2] >= NEAR:
            kept.append(a)
        if (a[2] >= NEAR) != (b[2] >= NEAR):
            kept.append(a + (b - a) * (NEAR - a[2]) / (b[2] - a[2]))
    if not kept:
        return None
    p = np.array(kept)
    x, y = cam.fx * p[:, 0] / p[:, 2] + cam.cx, cam.fy * p[:, 1] / p[:, 2] + cam.cy
    c0, c1 = max(int(np.floor(x.min())) - 1, 0), min(int(np.ceil(x.max())) + 1, cam.width)
    r0, r1 = max(int(np.floor(y.min())) - 1, 0), min(int(np.ceil(y.max())) + 1, cam.height)
    return (r0, r1, c0, c1) if r0 < r1 and c0 < c1 else None


def render(scene: Scene, cam: PinholeCamera, cam_from_world: tuple[np.ndarray, np.ndarray]):
    """Ray-cast one view: (H, W, 3) linear colour and (H, W) float32 z-depth (0 = no hit)."""
    r, t = cam_from_world
    center = -r.T @ t
    k_inv = np.array([[1 / cam.fx, 0, -cam.cx / cam.fx], [0, 1 / cam.fy, -cam.cy / cam.fy], [0, 0, 1]])
    world_from_pixel = r.T @ k_inv  # ray direction (z_cam = 1) of homogeneous pixel (u, v, 1)
    us = np.arange(cam.width, dtype=np.float64) + 0.5
    vs = np.arange(cam.height, dtype=np.float64) + 0.5
    shape = (cam.height, cam.width)
    depth, ids = np.full(shape, np.inf), np.full(shape, -1, np.int32)
    s_map, t_map = np.zeros(shape), np.zeros(shape)

    for k, q in enumerate(scene.quads):
        box = _pixel_box(q, r, t, cam)
        if box is None:
            continue
        r0, r1, c0, c1 = box
        u, v = us[None, c0:c1], vs[r0:r1, None]

        def linear(vec: np.ndarray, u=u, v=v) -> np.ndarray:
            a = world_from_pixel.T @ vec
            return a[0] * u + a[1] * v + a[2]

        n = np.cross(q.u, q.v)
        with np.errstate(divide="ignore", invalid="ignore"):
            hit = (n @ (q.origin - center)) / linear(n)
        rel = center - q.origin
        s = (rel @ q.u + hit * linear(q.u)) / (q.u @ q.u)
        tt = (rel @ q.v + hit * linear(q.v)) / (q.v @ q.v)
        win = (hit > NEAR) & (hit < depth[r0:r1, c0:c1]) & (s >= 0) & (s <= 1) & (tt >= 0) & (tt <= 1)
        depth[r0:r1, c0:c1][win] = hit[win]
        ids[r0:r1, c0:c1][win] = k
        s_map[r0:r1, c0:c1][win] = s[win]
        t_map[r0:r1, c0:c1][win] = tt[win]

    rgb = _shade(scene, cam, world_from_pixel, center, depth, ids, s_map, t_map)
    depth[ids < 0] = 0.0
    return rgb, depth.astype(np.float32)


def _shade(scene, cam, world_from_pixel, center, depth, ids, s_map, t_map) -> np.ndarray:
    flat_ids = ids.ravel()
    order = np.argsort(flat_ids, kind="stable")
    bounds = np.searchsorted(flat_ids[order], np.arange(len(scene.quads) + 1))
    pix = np.stack(
        [
            np.tile(np.arange(cam.width) + 0.5, cam.height),
            np.repeat(np.arange(cam.height) + 0.5, cam.width),
            np.ones(ids.size),
        ],
        axis=1,
    )
    out = np.zeros((ids.size, 3), np.float32)
    for k, q in enumerate(scene.quads):
        idx = order[bounds[k] : bounds[k + 1]]
        if idx.size == 0:
            continue
        d = pix[idx] @ world_from_pixel.T
        z = depth.ravel()[idx]
        n = q.normal
        cos = np.abs(d @ n) / np.linalg.norm(d, axis=1)
        tex = scene.textures[q.texture]
        h0, w0 = tex.levels[0].shape[:2]
        texels_per_m = max(w0 / np.linalg.norm(q.u), h0 / np.linalg.norm(q.v))
        footprint = z * np.linalg.norm(d, axis=1) / cam.fx / np.sqrt(np.maximum(cos, 0.05))
        level = np.clip(np.log2(np.maximum(footprint * texels_per_m, 1e-6)), 0, len(tex.levels) - 1)
        l0 = np.minimum(level.astype(np.int64), len(tex.levels) - 2) if len(tex.levels) > 1 else level * 0
        frac = (level - l0)[:, None]
        s, t = s_map.ravel()[idx], t_map.ravel()[idx]
        col = np.empty((idx.size, 3))
        for lvl in np.unique(l0):
            m = l0 == lvl
            a = tex.sample(int(lvl), s[m], t[m])
            b = tex.sample(int(lvl) + 1, s[m], t[m]) if len(tex.levels) > 1 else a
            col[m] = a * (1 - frac[m]) + b * frac[m]
        out[idx] = col * _light(scene, q, center + d * z[:, None], d)[:, None]
    return out.reshape(cam.height, cam.width, 3)


def _light(scene: Scene, q: Quad, points: np.ndarray, d: np.ndarray) -> np.ndarray:
    n = q.normal
    if q.flat:
        return np.full(len(points), 0.95 + 0.1 * n[2])
    facing = n if (d[0] @ n) < 0 else -n
    shade = np.full(len(points), scene.ambient)
    for light in scene.lights:
        to_light = light - points
        dist = np.linalg.norm(to_light, axis=1)
        cos = np.maximum(to_light @ facing / np.maximum(dist, 1e-6), 0.0)
        shade += 0.45 * cos / (1 + (dist / 2.5) ** 2)
    return shade
