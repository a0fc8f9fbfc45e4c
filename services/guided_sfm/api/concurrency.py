"""At most as many API requests in flight as the database pool has connections; the rest wait
their turn without holding a thread or a connection.

Why: a request takes a pooled connection at its first query, then needs a worker thread for each
of its sync steps (dependencies, the route). With more requests in flight than connections, the
threads block on the pool while the connections' holders wait for a thread, and everything stalls
until the pool's timeout: 70 clients polling got 30 s answers and 500s (benchmarks/bench_api.py)."""

from __future__ import annotations

import asyncio

from sqlalchemy.orm import Session, sessionmaker
from starlette.types import ASGIApp, Receive, Scope, Send

API_PREFIX = "/api/"


def pool_capacity(sessions: sessionmaker[Session]) -> int | None:
    """Connections the sessions' engine may open at once; None when it has no bounded pool."""
    pool = getattr(sessions.kw.get("bind"), "pool", None)
    size = getattr(pool, "size", None)
    if not callable(size):
        return None
    return size() + max(int(getattr(pool, "_max_overflow", 0)), 0)


class ConcurrencyLimit:
    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app = app
        self.slots = asyncio.Semaphore(limit)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith(API_PREFIX):
            await self.app(scope, receive, send)
            return
        async with self.slots:
            await self.app(scope, receive, send)
