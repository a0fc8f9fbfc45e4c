"""Procedural textures (uint8 RGB arrays) with multi-scale detail for SIFT; every call is seeded."""

from __future__ import annotations

import string

import numpy as np
import PIL.Image
import PIL.ImageDraw
import PIL.ImageFont

_FONTS: dict[int, PIL.ImageFont.FreeTypeFont | PIL.ImageFont.ImageFont] = {}


def _font(size: int) -> PIL.ImageFont.FreeTypeFont | PIL.ImageFont.ImageFont:
    if size not in _FONTS:
        _FONTS[size] = PIL.ImageFont.load_default(size=size)
    return _FONTS[size]


def value_noise(rng: np.random.Generator, h: int, w: int, cell: float) -> np.ndarray:
    """Smooth noise in about [-2, 2] with features of `cell` texels (bilinear, smoothstep)."""
    gh, gw = int(h / cell) + 2, int(w / cell) + 2
    grid = rng.standard_normal((gh, gw)).astype(np.float32)
    ys, xs = np.arange(h, dtype=np.float32) / cell, np.arange(w, dtype=np.float32) / cell
    y0, x0 = ys.astype(np.int64), xs.astype(np.int64)
    fy, fx = ys - y0, xs - x0
    fy, fx = (fy * fy * (3 - 2 * fy))[:, None], (fx * fx * (3 - 2 * fx))[None, :]
    top = grid[y0][:, x0] * (1 - fx) + grid[y0][:, x0 + 1] * fx
    bottom = grid[y0 + 1][:, x0] * (1 - fx) + grid[y0 + 1][:, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def fbm(rng: np.random.Generator, h: int, w: int, cell: float, octaves: int = 5) -> np.ndarray:
    """Fractal noise: octaves of value noise halving in size and amplitude."""
    out = np.zeros((h, w), np.float32)
    for k in range(octaves):
        if cell / 2**k < 1.0:
            break
        out += value_noise(rng, h, w, cell / 2**k) * 0.55**k
    return out


def _colour(rng: np.random.Generator, lo: int = 0, hi: int = 256) -> tuple[int, int, int]:
    return tuple(int(c) for c in rng.integers(lo, hi, 3))


def _modulate(img: PIL.Image.Image, rng: np.random.Generator, amp: float, cell: float) -> np.ndarray:
    arr = np.asarray(img, dtype=np.float32)
    h, w = arr.shape[:2]
    light = 1.0 + amp * fbm(rng, h, w, cell)
    grain = rng.normal(0.0, 4.0, (h, w, 1)).astype(np.float32)
    return np.clip(arr * light[..., None] + grain, 0, 255).astype(np.uint8)


def _words(rng: np.random.Generator, n: int) -> str:
    letters = string.ascii_letters + "0123456789"
    return " ".join("".join(rng.choice(list(letters), int(rng.integers(2, 9)))) for _ in range(n))


def _scribbles(
    draw: PIL.ImageDraw.ImageDraw,
    rng: np.random.Generator,
    w: int,
    h: int,
    n: int,
    size: tuple[int, int],
    palette: tuple[int, int] = (0, 256),
) -> None:
    for _ in range(n):
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        sx, sy = (int(v) for v in rng.integers(size[0], size[1], 2))
        kind, col = int(rng.integers(0, 5)), _colour(rng, *palette)
        if kind == 0:
            draw.rectangle([x, y, x + sx, y + sy], fill=col)
        elif kind == 1:
            draw.ellipse([x, y, x + sx, y + sy], fill=col)
        elif kind == 2:
            pts = [(x + int(rng.integers(-sx, sx)), y + int(rng.integers(-sy, sy))) for _ in range(5)]
            draw.line(pts, fill=col, width=int(rng.integers(1, max(2, sx // 6))))
        elif kind == 3:
            pts = [(x + int(rng.integers(-sx, sx)), y + int(rng.integers(-sy, sy))) for _ in range(3)]
            draw.polygon(pts, fill=col)
        else:
            draw.text((x, y), _words(rng, 2), fill=col, font=_font(max(8, sy // 2)))


def mural(rng: np.random.Generator, w: int, h: int) -> np.ndarray:
    """An abstract painting: layered shapes and strokes from large to small, bright colours."""
    img = PIL.Image.new("RGB", (w, h), _colour(rng, 60, 200))
    draw = PIL.ImageDraw.Draw(img)
    for scale in (0.5, 0.25, 0.12, 0.06, 0.03):
        s = int(min(w, h) * scale)
        _scribbles(draw, rng, w, h, int(6 / scale), (max(2, s // 2), max(3, s)))
    return _modulate(img, rng, 0.15, w / 6)


def poster(rng: np.random.Generator, w: int, h: int) -> np.ndarray:
    """A printed poster: coloured title band, a picture, paragraphs of text, a border."""
    img = PIL.Image.new("RGB", (w, h), _colour(rng, 200, 256))
    draw = PIL.ImageDraw.Draw(img)
    band = int(h * 0.18)
    draw.rectangle([0, 0, w, band], fill=_colour(rng, 0, 180))
    draw.text((w // 20, band // 4), _words(rng, 2), fill=_colour(rng, 200, 256), font=_font(band // 2))
    pic = [w // 12, band + h // 20, w - w // 12, int(h * 0.6)]
    draw.rectangle(pic, fill=_colour(rng))
    pw, ph = pic[2] - pic[0], pic[3] - pic[1]
    sub = PIL.Image.new("RGB", (pw, ph), _colour(rng))
    _scribbles(PIL.ImageDraw.Draw(sub), rng, pw, ph, 60, (pw // 20 + 2, pw // 4 + 3))
    img.paste(sub, (pic[0], pic[1]))
    line, y = max(8, h // 40), int(h * 0.63)
    while y < h - 2 * line:
        draw.text((w // 12, y), _words(rng, 6), fill=_colour(rng, 0, 90), font=_font(line))
        y += int(line * 1.5)
    draw.rectangle([0, 0, w - 1, h - 1], outline=_colour(rng, 0, 80), width=max(2, w // 60))
    return _modulate(img, rng, 0.05, w / 4)


def plaster(rng: np.random.Generator, w: int, h: int, marks: int = 40) -> np.ndarray:
    """A painted wall: mottled paint, a skirting band, scattered marks, notes and fixtures."""
    base = np.array(_colour(rng, 150, 230), np.float32)
    arr = base * (1.0 + 0.12 * fbm(rng, h, w, w / 3, 7))[..., None]
    img = PIL.Image.fromarray(np.clip(arr, 0, 255).astype(np.uint8))
    draw = PIL.ImageDraw.Draw(img)
    clean = img.copy()
    draw.rectangle([0, int(h * 0.94), w, h], fill=_colour(rng, 40, 120))
    _scribbles(draw, rng, w, int(h * 0.9), marks, (w // 60 + 2, w // 12 + 3), (30, 230))
    # half-transparent marks read as faded paint, stains and pinned notes rather than confetti
    img = PIL.Image.blend(clean, img, 0.6)
    PIL.ImageDraw.Draw(img).rectangle([0, int(h * 0.94), w, h], fill=_colour(rng, 40, 120))
    return _modulate(img, rng, 0.08, w / 8)


def brick(rng: np.random.Generator, w: int, h: int, tpm: float) -> np.ndarray:
    """Bricks in running bond with grout, per-brick tint and noise (tpm = texels per metre)."""
    bw, bh, gap = int(0.24 * tpm), int(0.075 * tpm), max(1, int(0.01 * tpm))
    img = PIL.Image.new("RGB", (w, h), _colour(rng, 150, 200))
    draw = PIL.ImageDraw.Draw(img)
    base = np.array(_colour(rng, 90, 190))
    for row, y in enumerate(range(0, h, bh)):
        for x in range(-(row % 2) * bw // 2, w, bw):
            col = tuple(int(c) for c in np.clip(base + rng.normal(0, 18, 3), 0, 255))
            draw.rectangle([x + gap, y + gap, x + bw - 1, y + bh - 1], fill=col)
    _scribbles(draw, rng, w, h, 10, (w // 40 + 2, w // 10 + 3))
    return _modulate(img, rng, 0.15, bh)


def wood_floor(rng: np.random.Generator, w: int, h: int, tpm: float) -> np.ndarray:
    """Planks along the texture's x axis with grain, seams and scuffs."""
    plank = max(4, int(0.18 * tpm))
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    warp = fbm(rng, h, w, plank * 2, 4) * 3.0
    grain = 0.5 + 0.5 * np.sin((ys + warp * plank / 3) * (2 * np.pi / (plank / 5)))
    arr = np.empty((h, w, 3), np.float32)
    base = np.array(_colour(rng, 110, 190), np.float32)
    for y0 in range(0, h, plank):
        tint = base * rng.uniform(0.75, 1.2) * rng.uniform(0.95, 1.05, 3)
        rows = slice(y0, y0 + plank)
        arr[rows] = tint * (0.8 + 0.2 * grain[rows, :, None])
        for x in np.cumsum(rng.integers(int(0.8 * tpm), int(2.5 * tpm), 20)) - int(rng.integers(0, tpm)):
            if 0 <= x < w:
                arr[rows, x : x + 2] *= 0.45
        arr[y0 : y0 + 2] *= 0.45
    img = PIL.Image.fromarray(np.clip(arr, 0, 255).astype(np.uint8))
    _scribbles(PIL.ImageDraw.Draw(img), rng, w, h, int(w * h / tpm**2 * 3), (3, plank), (20, 120))
    return _modulate(img, rng, 0.12, tpm)


def tiles(rng: np.random.Generator, w: int, h: int, tpm: float, size_m: float = 0.5) -> np.ndarray:
    """Square floor or ceiling tiles with grout, mottling and speckles."""
    t, gap = int(size_m * tpm), max(1, int(0.008 * tpm))
    img = PIL.Image.new("RGB", (w, h), _colour(rng, 60, 120))
    draw = PIL.ImageDraw.Draw(img)
    base = np.array(_colour(rng, 120, 230))
    for y in range(0, h, t):
        for x in range(0, w, t):
            col = tuple(int(c) for c in np.clip(base + rng.normal(0, 12, 3), 0, 255))
            draw.rectangle([x + gap, y + gap, x + t - 1, y + t - 1], fill=col)
    _scribbles(draw, rng, w, h, int(w * h / tpm**2 * 4), (2, t // 4 + 3), (30, 200))
    arr = _modulate(img, rng, 0.1, t / 2).astype(np.float32)
    speck = rng.random((h, w)) < 0.02
    arr[speck] *= 0.6
    return arr.astype(np.uint8)


def desk_top(rng: np.random.Generator, w: int, h: int, tpm: float) -> np.ndarray:
    """A desk surface: wood with papers of text, a keyboard grid and a mat."""
    arr = wood_floor(rng, w, h, tpm * 0.5)
    img = PIL.Image.fromarray(arr)
    draw = PIL.ImageDraw.Draw(img)
    for _ in range(3):
        pw, ph = int(0.21 * tpm), int(0.297 * tpm)
        x, y = int(rng.integers(0, w - pw)), int(rng.integers(0, h - ph))
        draw.rectangle([x, y, x + pw, y + ph], fill=(235, 235, 228))
        for ly in range(y + 6, y + ph - 8, 9):
            draw.text((x + 5, ly), _words(rng, 3), fill=(40, 40, 40), font=_font(7))
    kx, ky, key = int(0.35 * w), int(0.15 * h), max(3, int(0.018 * tpm))
    for r in range(5):
        for c in range(14):
            draw.rectangle(
                [kx + c * key, ky + r * key, kx + (c + 1) * key - 2, ky + (r + 1) * key - 2],
                fill=_colour(rng, 20, 70),
            )
    return np.asarray(img)


def panel(rng: np.random.Generator, w: int, h: int) -> np.ndarray:
    """A painted side panel with stickers and scuffs (for box and desk sides)."""
    img = PIL.Image.new("RGB", (w, h), _colour(rng, 60, 200))
    _scribbles(PIL.ImageDraw.Draw(img), rng, w, h, 30, (w // 30 + 2, w // 6 + 3))
    return _modulate(img, rng, 0.1, w / 4)
