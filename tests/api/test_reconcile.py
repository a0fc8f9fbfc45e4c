"""The reconciler removes what a crash left without rows (older than its grace) and nothing else."""

import os
import time

from guided_sfm.actions.reconcile import reconcile, reconcile_store
from guided_sfm.db.models import Version
from tests.factories import jpeg_bytes, make_project, signup


def _age(path, seconds=3600):
    stamp = time.time() - seconds
    os.utime(path, (stamp, stamp))


def test_orphans_older_than_the_grace_go_the_rest_stays(client, session, store):
    owner = signup(client, "alice")
    pid = make_project(client, owner)
    files = [("files", ("kept.jpg", jpeg_bytes(), "image/jpeg"))]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=owner).status_code == 201
    kept_version = store.project_dir(pid) / "versions" / "kept"
    kept_version.mkdir(parents=True)
    session.add(Version(project_id=pid, kind="reconstruct", path=f"projects/{pid}/versions/kept", stats={}))
    session.commit()
    _age(kept_version)
    orphans = [store.image_file(pid, "orphan.jpg"), store.thumbnail(pid, 999)]
    for path in orphans:
        path.write_bytes(b"x")
        _age(path)
    fresh = store.image_file(pid, "fresh.jpg")  # an upload between reveal and commit, maybe
    fresh.write_bytes(b"x")
    orphan_version = store.project_dir(pid) / "versions" / "orphan"  # a worker killed before commit
    orphan_version.mkdir()
    _age(orphan_version)
    gone_project = store.project_dir(pid + 1000) / "images"  # a deletion that crashed after commit
    gone_project.mkdir(parents=True)
    _age(gone_project.parent)
    removed = reconcile(session, store, grace_seconds=60)
    assert removed == {"projects": 1, "images": 1, "thumbs": 1, "versions": 1, "tmp": 0}
    assert not any(p.exists() for p in (*orphans, orphan_version, gone_project))
    assert fresh.exists() and kept_version.exists() and store.image_file(pid, "kept.jpg").exists()


def test_staging_a_crash_left_goes_once_older_than_a_job_may_run(client, session, store, settings, sessions):
    """Request staging (upload-, import-, thumb-) goes after the grace; any other staging (a job's,
    an export's, a restore's) only once older than the project's job time limit, which no live
    process outlives (the heartbeat ends a job that reaches it)."""
    owner = signup(client, "alice")
    pid = make_project(client, owner)
    files = [("files", ("kept.jpg", jpeg_bytes(), "image/jpeg"))]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=owner).status_code == 201
    limit = settings.job_base_seconds + settings.job_seconds_per_image * 1  # one image
    tmp = store.project_dir(pid) / "tmp"
    grace = settings.orphan_grace_seconds
    ages = {"upload-old": grace + 60, "export-old": limit + 60, "restore-old": limit + 60,
            "job-3-old": limit + 60, "export-young": limit - 60, "job-4-young": limit - 60,
            "restore-young": grace + 60}
    for name, age in ages.items():
        (tmp / name / "workspace").mkdir(parents=True)
        _age(tmp / name, age)
    removed = reconcile_store(sessions, settings)
    assert removed["tmp"] == 4
    assert sorted(p.name for p in tmp.iterdir()) == ["export-young", "job-4-young", "restore-young"]
