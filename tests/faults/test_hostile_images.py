"""Hostile images through a real API process: a decompression bomb and an image over the pixel
cap are refused with 422 naming the limit, read from the header before any decode."""

from __future__ import annotations

import struct
import zlib

from tests.factories import jpeg_bytes
from tests.faults.conftest import login
from tests.faults.test_sqlite_writes import _multipart


def png_bomb(width: int = 15000, height: int = 15000) -> bytes:
    """A small PNG (1-bit, all zero rows, deflated) that declares width x height pixels."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    row, packer = b"\0" * (1 + (width + 7) // 8), zlib.compressobj(9)
    idat = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _upload(api, headers, pid, name, data):
    body, extra = _multipart(name, data)
    return api.request("POST", f"/api/v1/projects/{pid}/images", data=body, headers={**headers, **extra})


def test_bomb_and_pixel_cap_are_422(live_factory):
    api = live_factory(max_image_mpx=2)
    headers = login(api, "mallory")
    pid = api.request("POST", "/api/v1/projects", {"name": "bombs"}, headers)[1]["id"]
    bomb = png_bomb()
    assert len(bomb) < 64 * 1024
    rss_before = api.rss_mb()
    status, body, _ = _upload(api, headers, pid, "bomb.png", bomb)
    assert status == 422, body
    assert "225.0 Mpx" in body["detail"] and "limit of 2 Mpx" in body["detail"], body
    status, body, _ = _upload(api, headers, pid, "big.jpg", jpeg_bytes(2000, 1500))
    assert status == 422 and "3.0 Mpx" in body["detail"], body
    assert "GUIDED_SFM_MAX_IMAGE_MPX" in body["detail"], body
    assert api.rss_mb() - rss_before < 50  # nothing was decoded whole
    assert _upload(api, headers, pid, "fine.jpg", jpeg_bytes(1600, 1200))[0] == 201
    assert api.request("GET", f"/api/v1/projects/{pid}/images", headers=headers)[1] != []
