"""The collection pass (actions/reconcile.py) on both backends: keys no row references are removed
once older than the grace, whatever a row references stays, and a fresh orphan waits its grace."""

from __future__ import annotations

from pathlib import Path

from guided_sfm.actions import projects
from guided_sfm.actions.reconcile import reconcile
from guided_sfm.db.models import Image, User, Version
from guided_sfm.storage import Store, image_key, project_prefix, thumb_key

NEVER_FRESH = -3600.0  # a grace in the past: every orphan counts as old (S3 times cannot be set back)


def put(store: Store, key: str, tmp_path: Path, data: bytes = b"x") -> None:
    source = tmp_path / "src" / key.replace("/", "_")
    source.parent.mkdir(parents=True, exist_ok=True)
    source.write_bytes(data)
    store.put(key, source)


def version(store: Store, pid: int, tmp_path: Path) -> str:
    with store.staging(pid) as scratch:
        (scratch / "ws").mkdir()
        (scratch / "ws" / "database.db").write_bytes(b"db")
        return store.publish(pid, scratch / "ws")


def project_with_rows(session, store: Store, tmp_path: Path) -> tuple[int, str, int]:
    user = User(username="alice", password_hash="x")
    session.add(user)
    session.flush()
    pid = projects.add(session, user.id, "p").id
    image = Image(project_id=pid, name="kept.jpg", width=4, height=3, seq=0)
    kept = version(store, pid, tmp_path)
    session.add_all([image, Version(project_id=pid, kind="reconstruct", path=kept, stats={})])
    session.commit()
    put(store, image_key(pid, "kept.jpg"), tmp_path)
    put(store, thumb_key(pid, image.id), tmp_path)
    return pid, kept, image.id


def test_unreferenced_keys_are_collected_and_referenced_ones_stay(any_store, session, tmp_path):
    pid, kept, image_id = project_with_rows(session, any_store, tmp_path)
    put(any_store, image_key(pid, "orphan.jpg"), tmp_path)  # an upload that died before its commit
    put(any_store, thumb_key(pid, 999), tmp_path)
    orphan_version = version(any_store, pid, tmp_path)  # a job killed between publish and commit
    put(any_store, f"{project_prefix(pid + 1000)}/images/a.jpg", tmp_path)  # a deletion that crashed
    assert reconcile(session, any_store, grace_seconds=3600) == {
        "projects": 0, "images": 0, "thumbs": 0, "versions": 0, "tmp": 0}  # all fresh: wait
    removed = reconcile(session, any_store, grace_seconds=NEVER_FRESH)
    assert removed == {"projects": 1, "images": 1, "thumbs": 1, "versions": 1, "tmp": 0}
    assert not any_store.exists(image_key(pid, "orphan.jpg")) and not any_store.exists(thumb_key(pid, 999))
    assert any_store.children(project_prefix(pid + 1000)) == []
    assert any_store.children(f"{project_prefix(pid)}/versions") == [kept.rsplit("/", 1)[1]]
    assert orphan_version != kept
    assert any_store.exists(image_key(pid, "kept.jpg")) and any_store.exists(thumb_key(pid, image_id))
    with any_store.reading(kept) as root:
        assert (root / "database.db").read_bytes() == b"db"
