"""A stored file as a response: 200 with the bytes (no redirect, design.md v1.1), sent from the
data dir as a file or streamed from S3 as it arrives."""

from __future__ import annotations

import mimetypes
from urllib.parse import quote

from fastapi.responses import FileResponse, Response, StreamingResponse

from guided_sfm.storage import Blob


def blob_response(blob: Blob, media_type: str | None = None, filename: str | None = None) -> Response:
    if blob.path is not None:
        return FileResponse(blob.path, media_type=media_type, filename=filename)
    media_type = media_type or (mimetypes.guess_type(filename or "")[0] or "application/octet-stream")
    headers = {"Content-Length": str(blob.size)}
    if filename:
        headers["Content-Disposition"] = _attachment(filename)
    return StreamingResponse(blob.chunks, media_type=media_type, headers=headers)


def _attachment(filename: str) -> str:
    """As FileResponse writes it: plain when the name is ASCII-safe, else RFC 5987."""
    quoted = quote(filename)
    if quoted == filename:
        return f'attachment; filename="{filename}"'
    return f"attachment; filename*=utf-8''{quoted}"
