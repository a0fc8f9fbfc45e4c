"""Login and sign-up throttling, per username and per client address, in a sliding window held in
this API process (each API process counts on its own). The client address is the peer's, or, when
the peer is a trusted proxy (GUIDED_SFM_TRUSTED_PROXIES), the nearest untrusted X-Forwarded-For."""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict, deque

from starlette.requests import Request

from guided_sfm.errors import TooManyRequests
from guided_sfm.settings import Settings


class Throttle:
    def __init__(self, settings: Settings) -> None:
        self.window = settings.login_window_seconds
        self.limits = {"user": settings.login_attempts_per_user,
                       "address": settings.login_attempts_per_address}
        self.trusted = set(settings.trusted_proxy_list)
        self.events: dict[tuple[str, str], deque[float]] = defaultdict(deque)
        self.lock = threading.Lock()

    def client(self, request: Request) -> str:
        peer = request.client.host if request.client else "unknown"
        if peer not in self.trusted:
            return peer
        forwarded = [part.strip() for part in request.headers.get("x-forwarded-for", "").split(",")]
        untrusted = [address for address in forwarded if address and address not in self.trusted]
        return untrusted[-1] if untrusted else peer

    def check(self, kind: str, key: str) -> None:
        """TooManyRequests when `key` of `kind` ('user' or 'address') used up its attempts."""
        with self.lock:
            stamps = self._recent(kind, key)
            if len(stamps) >= self.limits[kind]:
                retry = max(1, math.ceil(stamps[0] + self.window - time.monotonic()))
                what = "this account" if kind == "user" else "your address"
                raise TooManyRequests(f"too many attempts for {what}; try again in {retry} s", retry)

    def record(self, kind: str, key: str) -> None:
        with self.lock:
            self._recent(kind, key).append(time.monotonic())

    def forget(self, kind: str, key: str) -> None:
        with self.lock:
            self.events.pop((kind, key), None)

    def _recent(self, kind: str, key: str) -> deque[float]:
        stamps, cutoff = self.events[(kind, key)], time.monotonic() - self.window
        while stamps and stamps[0] < cutoff:
            stamps.popleft()
        if not stamps:
            self.events.pop((kind, key), None)  # the table holds only keys with recent attempts
            stamps = self.events[(kind, key)]
        return stamps
