"""Request body limits counted on the bytes received (a chunked body declares no length): uploads
up to GUIDED_SFM_MAX_UPLOAD_MB, every other body (JSON, forms) up to 1 MiB; 413 before the rest
is read, so the API's memory stays bounded whatever a client sends."""

from __future__ import annotations

import re

from fastapi.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

SMALL_BODY = 1 << 20  # sign-up, token, edits, comments: far below this
UPLOAD_OVERHEAD = 1 << 20  # multipart headers around the files
UPLOAD_PATH = re.compile(r"^/api/v1/projects/[^/]+/(images|import)/?$")


class BodyTooLarge(Exception):
    """Raised into the app after the 413 went out, so it stops reading."""


class BodyLimit:
    def __init__(self, app: ASGIApp, upload_limit: int) -> None:
        self.app, self.upload_limit = app, upload_limit

    def limit_for(self, path: str) -> tuple[int, str]:
        if UPLOAD_PATH.match(path):
            return self.upload_limit + UPLOAD_OVERHEAD, f"the upload exceeds the limit of " \
                f"{self.upload_limit >> 20} MB (GUIDED_SFM_MAX_UPLOAD_MB)"
        return SMALL_BODY, f"the request body exceeds the limit of {SMALL_BODY >> 20} MB for this route"

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit, detail = self.limit_for(scope["path"])
        declared = dict(scope["headers"]).get(b"content-length", b"")
        if declared.isdigit() and int(declared) > limit:
            await JSONResponse({"detail": detail}, status_code=413)(scope, receive, send)
            return
        counter = _Counter(receive, send, limit, detail, scope)
        try:
            await self.app(scope, counter.receive, counter.send)
        except Exception:
            if not counter.refused:  # the app's own error; after a 413 the app's is only an echo
                raise


class _Counter:
    def __init__(self, receive: Receive, send: Send, limit: int, detail: str, scope: Scope) -> None:
        self._receive, self._send, self.limit, self.detail, self.scope = receive, send, limit, detail, scope
        self.received, self.started, self.refused = 0, False, False

    async def receive(self) -> Message:
        message = await self._receive()
        if message["type"] == "http.request":
            self.received += len(message.get("body", b""))
            if self.received > self.limit:
                if not self.started and not self.refused:
                    self.refused = True
                    await JSONResponse({"detail": self.detail}, status_code=413)(
                        self.scope, self._receive, self._send)
                raise BodyTooLarge(self.detail)
        return message

    async def send(self, message: Message) -> None:
        if self.refused:
            return  # the 413 is the answer; whatever the app makes of the cut body is dropped
        self.started = self.started or message["type"] == "http.response.start"
        await self._send(message)
