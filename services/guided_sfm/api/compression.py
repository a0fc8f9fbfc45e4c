"""gzip for large JSON answers (the scene) when the client accepts it."""

from __future__ import annotations

import gzip

from fastapi import Request, Response

# Below this a JSON answer is sent as is (gzip's header and the CPU cost buy nothing).
GZIP_MIN_BYTES = 1024
# Level 5: a scene's JSON (numbers, repeated keys) shrinks nearly as much as at 9, several times
# faster; the point is a 1,000-camera scene over a slow link, not the last few per cent.
GZIP_LEVEL = 5


def accepts_gzip(request: Request) -> bool:
    """Whether Accept-Encoding lists gzip (or *) without q=0."""
    for item in request.headers.get("accept-encoding", "").lower().split(","):
        name, _, params = item.strip().partition(";")
        quality = params.replace(" ", "").removeprefix("q=") if params else "1"
        if name in ("gzip", "*") and quality not in ("0", "0.0", "0.00", "0.000"):
            return True
    return False


def json_response(body: bytes | str, request: Request) -> Response:
    """Pre-serialized JSON, gzipped when the client takes it and it is worth it."""
    data = body.encode() if isinstance(body, str) else body
    headers = {"Vary": "Accept-Encoding"}
    if len(data) >= GZIP_MIN_BYTES and accepts_gzip(request):
        data = gzip.compress(data, GZIP_LEVEL)
        headers["Content-Encoding"] = "gzip"
    return Response(data, media_type="application/json", headers=headers)
