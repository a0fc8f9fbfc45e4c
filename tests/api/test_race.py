"""Optimistic concurrency under a real race: many clients PUT the same edit set with the same
If-Match at the same instant, against a real HTTP server on a committed database; exactly one wins
(200), every other gets 409, and the winner's body is what is stored."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
import uvicorn

from guided_sfm.api.app import create_app
from guided_sfm.db.session import make_sessionmaker
from guided_sfm.storage import ArtifactStore
from tests.conftest import make_settings
from tests.factories import PASSWORD, make_version

CLIENTS = 8
ROUNDS = 4


class LiveServer:
    """The API under uvicorn in a thread (its thread pool runs the sync routes in parallel)."""

    def __init__(self, app) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        self.server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True)

    def __enter__(self) -> LiveServer:
        self.thread.start()
        deadline = time.monotonic() + 60
        while not self.server.started:
            assert time.monotonic() < deadline and self.thread.is_alive(), "uvicorn did not start"
            time.sleep(0.05)
        return self

    def __exit__(self, *exc) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)
        self.sock.close()


@pytest.fixture
def live(tmp_path, committed_database, tiny_reconstruction,
         tiny_images) -> Iterator[tuple[str, dict, str, int]]:
    """(API url, owner headers, edit set path, base version id) on a database of its own."""
    settings = make_settings(tmp_path / "data", committed_database)
    sessions = make_sessionmaker(settings)
    with LiveServer(create_app(settings, lambda job_id: None, sessions=sessions)) as server:
        with httpx.Client(base_url=server.url + "/api/v1", timeout=120) as http:
            http.post("/users", json={"username": "ann", "password": PASSWORD}).raise_for_status()
            token = http.post("/auth/token", data={"username": "ann", "password": PASSWORD}).json()
            owner = {"Authorization": f"Bearer {token['access_token']}"}
            pid = http.post("/projects", json={"name": "race"}, headers=owner).json()["id"]
        with sessions() as session:
            vid = make_version(session, ArtifactStore(settings.artifacts_dir), pid, tiny_reconstruction,
                               tiny_images / "images").id
        with httpx.Client(base_url=server.url + "/api/v1", timeout=120) as http:
            eid = http.post(f"/projects/{pid}/edits", json={"base_version_id": vid, "cameras": []},
                            headers=owner).json()["id"]
        yield server.url + "/api/v1", owner, f"/projects/{pid}/edits/{eid}", vid
    sessions.kw["bind"].dispose()


def race(base: str, owner: dict, url: str, vid: int, revision: int) -> list[tuple[int, int, str]]:
    """CLIENTS PUTs released together by a barrier, each flagging its own image id 1..CLIENTS;
    (status, client number, body) of each."""
    barrier = threading.Barrier(CLIENTS)
    results: list[tuple[int, int, str]] = []

    def put(number: int) -> None:
        with httpx.Client(base_url=base, timeout=120) as http:
            body = {"base_version_id": vid, "cameras": [], "flags": [number]}
            barrier.wait()
            response = http.put(url, json=body, headers={**owner, "If-Match": str(revision)})
            results.append((response.status_code, number, response.text))

    threads = [threading.Thread(target=put, args=(n,)) for n in range(1, CLIENTS + 1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=180)
    return results


def test_same_revision_at_once_one_200_the_rest_409(live):
    base, owner, url, vid = live
    started = time.monotonic()
    for round_number in range(ROUNDS):
        revision = round_number + 1
        results = race(base, owner, url, vid, revision)
        statuses = sorted(status for status, _, _ in results)
        assert statuses == [200] + [409] * (CLIENTS - 1), results
        winner = next(number for status, number, _ in results if status == 200)
        with httpx.Client(base_url=base, timeout=120) as http:
            stored = http.get(url, headers=owner).json()
        assert stored["revision"] == revision + 1 and stored["flags"] == [winner], stored
    print(f"{ROUNDS} races of {CLIENTS} clients in {time.monotonic() - started:.1f} s")
