"""A job that meets the S3 store away (operations.md, "The store unavailable"): the worker waits
for it with back-off, its row saying so, and carries on when it is back; an outage longer than
GUIDED_SFM_STORE_WAIT_SECONDS fails the job naming the store, and the head stays as it was. The
job runs in-process (runner.run_job) on a database of its own, so a second thread can watch its
row; the store is moto's server behind the tests' TCP gate, which takes it away and brings it back."""

from __future__ import annotations

import shutil
import tempfile
import threading
import time

import pytest
from sqlalchemy import select

from guided_sfm import jobs
from guided_sfm.actions import runner, store_wait
from guided_sfm.actions.context import Produced
from guided_sfm.actions.publish import publish
from guided_sfm.actions.store_wait import StoreOutage, StoreWait
from guided_sfm.api.app import create_app
from guided_sfm.core.errors import Cancelled
from guided_sfm.core.sfm import CancelToken
from guided_sfm.db.models import Job, Project, Version
from guided_sfm.db.session import make_engine, make_sessionmaker
from guided_sfm.errors import Conflict
from guided_sfm.storage import StoreUnavailable, open_store
from guided_sfm.storage.s3 import S3Store
from tests.conftest import TestClient, make_settings
from tests.factories import make_project, signup, workspace_zip
from tests.s3server import CREDENTIALS, Gate

WAITING = "waiting for the artifact store"


@pytest.fixture
def gated(tmp_path, committed_database, moto_server, monkeypatch):
    """A function (wait seconds) -> (client, sessions, settings, gate, bucket) on a bucket behind a gate."""
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR: the store's scratch goes there
    (tmp_path / "tmp").mkdir()
    engine = make_engine(committed_database)
    gate, bucket, clients = Gate(moto_server.port), moto_server.new_bucket(), []

    def make(wait_seconds: float):
        settings = make_settings(tmp_path / "data", committed_database, artifacts_url=f"s3://{bucket}/art",
                                 s3_endpoint_url=gate.url, store_wait_seconds=wait_seconds)
        sessions = make_sessionmaker(engine)
        clients.append(TestClient(create_app(settings, lambda _job: None, sessions=sessions)).__enter__())
        return clients[-1], sessions, settings, gate, bucket

    yield make
    for client in clients:
        client.__exit__(None, None, None)
    gate.close()
    engine.dispose()


def queued_apply(client, sessions, settings, tiny_images, tiny_reconstruction) -> tuple[dict, int, int, int]:
    """(owner's headers, project id, head version id, job id): a project on the bucket whose head
    is the tiny reconstruction, and a queued apply (no remap) that deletes one of its pairs."""
    owner = signup(client, "owner")
    pid = make_project(client, owner, "wait")
    files = [("files", (p.name, p.read_bytes(), "image/jpeg"))
             for p in sorted((tiny_images / "images").iterdir())]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=owner).status_code == 201
    with sessions() as session:
        base = Version(project_id=pid, kind="reconstruct", message="t", stats={},
                       path=open_store(settings).publish(pid, tiny_reconstruction))
        session.add(base)
        session.flush()
        session.get(Project, pid).head_version_id = base.id
        session.commit()
        head = base.id
    api = f"/api/v1/projects/{pid}"
    pair = client.get(f"{api}/versions/{head}/pairs", headers=owner).json()[0]
    body = {"base_version_id": head, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}
    edit = client.post(f"{api}/edits", json=body, headers=owner).json()
    job = client.post(f"{api}/edits/{edit['id']}/apply", json={"remap": False}, headers=owner).json()
    return owner, pid, head, job["id"]


def open_when_waiting(sessions, job_id: int, gate: Gate, seen: list[str]) -> threading.Thread:
    """A thread that brings the store back once the job's row says it waits for it."""

    def watch() -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            with sessions() as session:
                message = session.scalar(select(Job.message).where(Job.id == job_id)) or ""
            if WAITING in message:
                seen.append(message)
                gate.open()
                return
            time.sleep(0.1)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


@pytest.mark.parametrize("when", ["fetch", "publish"])
def test_a_job_waits_for_the_store_and_carries_on_when_it_is_back(when, gated, monkeypatch, tiny_images,
                                                                  tiny_reconstruction):
    """Away when the job fetches its base, or when it publishes its result (closed after the
    action returns): either way the job says it waits, then succeeds once the store is back."""
    client, sessions, settings, gate, _ = gated(wait_seconds=120)
    owner, pid, head, job_id = queued_apply(client, sessions, settings, tiny_images, tiny_reconstruction)
    if when == "fetch":
        gate.close()
    else:
        action = runner.ACTIONS["apply"]

        def then_close(context, work):
            produced = action(context, work)
            gate.close()
            return produced

        monkeypatch.setitem(runner.ACTIONS, "apply", then_close)
    seen: list[str] = []
    watcher = open_when_waiting(sessions, job_id, gate, seen)
    assert runner.run_job(sessions, settings, job_id) == "succeeded"
    watcher.join(timeout=1)
    assert seen and "artifact store unavailable" in seen[0], seen
    with sessions() as session:
        job, project = session.get(Job, job_id), session.get(Project, pid)
        assert job.state == "succeeded" and project.head_version_id == job.version_id != head
        assert WAITING not in job.message, job.message  # the end's message, not the wait's
    api = f"/api/v1/projects/{pid}/versions"
    before = client.get(f"{api}/{head}/pairs", headers=owner).json()
    after = client.get(f"{api}/{job.version_id}/pairs", headers=owner).json()
    assert len(after) == len(before) - 1  # the new version reads back whole


def test_an_outage_longer_than_the_wait_fails_the_job_naming_the_store(gated, moto_server, tiny_images,
                                                                       tiny_reconstruction):
    client, sessions, settings, gate, bucket = gated(wait_seconds=3)
    owner, pid, head, job_id = queued_apply(client, sessions, settings, tiny_images, tiny_reconstruction)
    keys = set(moto_server.objects(bucket))
    gate.close()
    assert runner.run_job(sessions, settings, job_id) == "failed"
    with sessions() as session:
        job = session.get(Job, job_id)
        assert "artifact store unavailable" in job.error and "GUIDED_SFM_STORE_WAIT_SECONDS" in job.error
        assert "head is unchanged" in job.error, job.error
        assert session.get(Project, pid).head_version_id == head
        assert session.scalars(select(Version.id).where(Version.project_id == pid)).all() == [head]
    gate.open()
    assert set(moto_server.objects(bucket)) == keys  # nothing half-written, nothing lost
    pairs = client.get(f"/api/v1/projects/{pid}/versions/{head}/pairs", headers=owner)
    assert pairs.status_code == 200 and pairs.json()  # the previous version reads as before


def away(calls: list[float]):
    """A step that finds the store away every time, noting when it was tried."""

    def step():
        calls.append(time.monotonic())
        raise StoreUnavailable("artifact store unavailable (SlowDown)")

    return step


def test_the_wait_backs_off_and_is_bounded():
    calls, said = [], []
    with pytest.raises(StoreOutage, match=r"SlowDown\) for \d+ s, longer than a job waits"):
        StoreWait(3.5, said.append, CancelToken()).run(away(calls))
    gaps = [later - earlier for earlier, later in zip(calls, calls[1:], strict=False)]
    # pauses of 1 s, then 2 s, then what is left of the 3.5 s (0.5 s), then one last try
    assert len(calls) == 4 and gaps[1] > 1.5 * gaps[0] and gaps[2] < gaps[1], gaps
    assert len(said) == 3 and all(WAITING in s for s in said)


def test_a_cancel_ends_the_wait():
    token = CancelToken()
    threading.Timer(0.3, token.cancel).start()
    with pytest.raises(Cancelled):
        StoreWait(600, lambda _: None, token).run(away([]))


def test_an_import_whose_fetch_met_the_store_away_keeps_its_upload_for_the_next_try(
        gated, monkeypatch, tiny_images, tiny_reconstruction):
    """The store away while the import fetches its zip, and back at once (a read that timed out
    while deletes go through): the zip must still be there for the next try, not removed as if
    the import had read it."""
    client, sessions, settings, gate, _ = gated(wait_seconds=60)
    owner = signup(client, "owner")
    pid = make_project(client, owner, "import")
    files = {"file": ("ws.zip", workspace_zip(tiny_reconstruction, tiny_images / "images"))}
    job_id = client.post(f"/api/v1/projects/{pid}/import", files=files, headers=owner).json()["id"]
    first_fetch = []

    class AwayForTheFirstFetch(S3Store):
        def fetch(self, key, target):
            if first_fetch:
                return super().fetch(key, target)
            first_fetch.append(key)
            gate.close()
            try:
                return super().fetch(key, target)
            finally:
                gate.open()

    store = open_store(settings)
    monkeypatch.setattr(runner, "open_store", lambda _settings: AwayForTheFirstFetch(
        store.client, store.bucket, store.prefix))
    assert runner.run_job(sessions, settings, job_id) == "succeeded", sessions().get(Job, job_id).error
    assert first_fetch and "/uploads/" in first_fetch[0]


def test_a_publish_refused_by_the_database_says_so_when_its_cleanup_meets_the_store_away(
        gated, moto_server, tiny_images, tiny_reconstruction):
    """Published, then refused (the sweeper ended the job meanwhile), and the store gone as the
    publish removes what it wrote: the refusal is what the job ends on, not a store outage to
    wait out (the objects left are the reconciler's)."""
    client, sessions, settings, gate, bucket = gated(wait_seconds=60)
    _, pid, _, job_id = queued_apply(client, sessions, settings, tiny_images, tiny_reconstruction)
    with sessions() as session:
        assert jobs.claim(session, job_id)
        jobs.finish(session, job_id, "failed", error="the sweeper gave up on it")
        session.commit()

    class AwayForTheCleanup(S3Store):
        def discard(self, version):
            gate.close()
            return super().discard(version)

    plain = open_store(settings)
    store = AwayForTheCleanup(plain.client, plain.bucket, plain.prefix)
    keys = set(moto_server.objects(bucket))
    with store.staging(pid) as staging, sessions() as session:
        shutil.copytree(tiny_reconstruction, staging / "ws")
        produced = Produced(staging / "ws", "reconstruct", "reconstructed", None, {"num_images": 12})
        with pytest.raises(Conflict, match="ended by someone else"):
            publish(session, store, session.get(Job, job_id), produced)
    gate.open()
    assert set(moto_server.objects(bucket)) > keys  # what it wrote stays, for the reconciler


class Clock:
    """time as store_wait reads it, moved by the test: sleeping moves it on."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_the_wait_counts_from_when_the_store_last_answered(monkeypatch):
    """Away at the first try; the second try's calls answer for longer than the wait, then one
    does not: a new outage, not one that has lasted since the first try. The third try runs."""
    clock, answered = Clock(), []
    monkeypatch.setattr(store_wait, "time", clock)

    def step():
        tries.append(clock.now)
        if len(tries) == 2:
            clock.now += 100.0  # a long fetch the store answers ...
            answered.append(clock.now)
            clock.now += 0.1  # ... then a call it does not
        if len(tries) < 3:
            raise StoreUnavailable("artifact store unavailable (SlowDown)")
        return "done"

    tries: list[float] = []
    wait = StoreWait(10.0, lambda _: None, CancelToken(), answered=lambda: answered[-1] if answered else None)
    assert wait.run(step) == "done" and len(tries) == 3


def test_an_s3_store_notes_when_it_last_answered(moto_server, monkeypatch):
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    store = S3Store.from_url(f"s3://{moto_server.new_bucket()}/art", moto_server.url)
    assert store.answered_at is None
    before = time.monotonic()
    store.put_bytes("probe", b"1")
    assert store.answered_at is not None and store.answered_at >= before


def test_a_fetch_of_many_files_stops_at_the_first_store_error(tmp_path):
    """The store away while a job fetches its images: the step fails once the first fetch does,
    so the wait (and a cancel) can act, not after every queued fetch has met the outage too
    (with a hung endpoint each takes its tries of 10 s: hours for a thousand images)."""
    calls = []

    class Away(S3Store):
        def fetch(self, key, target):
            calls.append(key)
            time.sleep(0.02)  # a call's tries against an endpoint that is away
            raise StoreUnavailable("artifact store unavailable (SlowDown)")

    with pytest.raises(StoreUnavailable):
        Away(None, "bucket").images_for(1, [f"{i}.jpg" for i in range(400)], tmp_path)
    assert len(calls) < 100, len(calls)  # the fetches already running, not all 400
