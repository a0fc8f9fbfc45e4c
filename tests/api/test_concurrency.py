"""More clients at once than the database pool has connections: they take turns, none stalls on
the pool's timeout (70 pollers got 30 s answers and 500s before the API limited requests in flight)."""

import asyncio
import time

import httpx

from guided_sfm.api.app import create_app
from guided_sfm.db.session import make_engine, make_sessionmaker
from tests.conftest import create_database, make_settings
from tests.factories import PASSWORD

CLIENTS = 60


async def poll_at_once(app, headers: dict, paths: list[str]) -> list[int]:
    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url="http://test", timeout=60) as client:
        calls = [client.request(*path.split(" ", 1), headers=headers) for path in paths]
        answers = await asyncio.gather(*calls)
    return [answer.status_code for answer in answers]


async def sign_up(app) -> dict:
    transport = httpx.ASGITransport(app=app)
    account = {"username": "many", "password": PASSWORD}
    async with httpx.AsyncClient(transport=transport, base_url="http://test") as client:
        await client.post("/api/v1/users", json=account)
        token = (await client.post("/api/v1/auth/token", data=account)).json()["access_token"]
        headers = {"Authorization": f"Bearer {token}"}
        pid = (await client.post("/api/v1/projects", json={"name": "busy"}, headers=headers)).json()["id"]
    return headers, pid


def test_more_clients_than_connections_take_turns(tmp_path):
    url, drop = create_database(tmp_path)
    engine = make_engine(url, pool_size=2, max_overflow=0, pool_timeout=5)
    try:
        app = create_app(make_settings(tmp_path / "data", url), lambda job_id: None,
                         sessions=make_sessionmaker(engine))
        headers, pid = asyncio.run(sign_up(app))
        paths = [f"GET /api/v1/projects/{pid}/jobs", f"POST /api/v1/projects/{pid}/presence"] * (CLIENTS // 2)
        started = time.monotonic()
        codes = asyncio.run(poll_at_once(app, headers, paths))
        assert codes == [200] * CLIENTS, sorted(set(codes))
        assert time.monotonic() - started < 5  # no request waited for the pool's timeout
    finally:
        engine.dispose()
        drop()
