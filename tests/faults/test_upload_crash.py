"""The API killed (SIGKILL) between revealing an upload's files and committing its rows: after a
restart no file is left without a row, and the same names upload again."""

from __future__ import annotations

import contextlib
import os
import threading
from pathlib import Path

from sqlalchemy import func, select

from guided_sfm.db.models import Image
from guided_sfm.db.session import make_engine
from tests.factories import jpeg_bytes, zip_bytes
from tests.faults.conftest import login
from tests.faults.live_api import LiveApi
from tests.faults.test_sqlite_writes import _multipart

COUNT = 300  # enough files that revealing them takes a few milliseconds


def _rows(database_url: str, pid: int) -> int:
    engine = make_engine(database_url)
    with engine.connect() as conn:
        count = conn.scalar(select(func.count()).select_from(Image).where(Image.project_id == pid))
    engine.dispose()
    return count


def _kill_when_revealed(api: LiveApi, headers, pid: int, folder: Path) -> None:
    """Upload COUNT images as one zip and SIGKILL the API as soon as the first file is in place."""
    archive = zip_bytes({f"img{i:04d}.jpg": jpeg_bytes(color=(i % 256, 7, 9)) for i in range(COUNT)})
    body, extra = _multipart("all.zip", archive)
    thread = threading.Thread(target=lambda: _ignore_errors(
        api.request, "POST", f"/api/v1/projects/{pid}/images", data=body, headers={**headers, **extra}))
    thread.start()
    while api.process.poll() is None:
        if folder.is_dir() and os.listdir(folder):
            api.kill()
            break
    thread.join(timeout=60)


def _ignore_errors(call, *args, **kwargs) -> None:
    with contextlib.suppress(OSError):  # the API died mid-request, as intended
        call(*args, **kwargs)


def test_kill_between_reveal_and_commit_leaves_no_orphan(live_factory, tmp_path):
    api = live_factory(orphan_grace_seconds=0)
    headers = login(api, "crash")
    for attempt in range(3):  # the kill must land between the first file and the commit
        pid = api.request("POST", "/api/v1/projects", {"name": f"p{attempt}"}, headers)[1]["id"]
        folder = tmp_path / "data" / "artifacts" / "projects" / str(pid) / "images"
        _kill_when_revealed(api, headers, pid, folder)
        if _rows(api.database_url, pid) == 0 and os.listdir(folder):
            break
        api = LiveApi(api.env, tmp_path / f"again-{attempt}.log").start()
    else:
        api.kill()
        raise AssertionError("the kill never landed between reveal and commit")
    restarted = LiveApi(api.env, tmp_path / "restarted.log").start()
    try:
        assert sorted(os.listdir(folder)) == [], "orphans left after the restart"
        body, extra = _multipart("img0000.jpg", jpeg_bytes())
        status, answer, _ = restarted.request("POST", f"/api/v1/projects/{pid}/images", data=body,
                                              headers={**headers, **extra})
        assert status == 201, answer
        assert _rows(api.database_url, pid) == 1 and os.listdir(folder) == ["img0000.jpg"]
    finally:
        restarted.kill()
