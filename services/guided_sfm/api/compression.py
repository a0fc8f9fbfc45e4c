"""Whether a client takes gzip (the scene is sent gzipped to those that do)."""

from __future__ import annotations

from fastapi import Request


def accepts_gzip(request: Request) -> bool:
    """Whether Accept-Encoding lists gzip (or *) without q=0."""
    for item in request.headers.get("accept-encoding", "").lower().split(","):
        name, _, params = item.strip().partition(";")
        quality = params.replace(" ", "").removeprefix("q=") if params else "1"
        if name in ("gzip", "*") and quality not in ("0", "0.0", "0.00", "0.000"):
            return True
    return False

