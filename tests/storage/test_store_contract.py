"""The store's contract, one suite for both backends (the data dir and S3 over HTTP): files by key,
versions published whole and read back as published, scratch emptied, collection of orphans."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from guided_sfm.storage import ArtifactStore, Store, image_key, thumb_key
from guided_sfm.storage.s3 import S3Store

PID = 7


def blob_bytes(store: Store, key: str) -> bytes:
    blob = store.blob(key)
    data = blob.path.read_bytes() if blob.path is not None else b"".join(blob.chunks)
    assert len(data) == blob.size
    return data


def write(path: Path, data: bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def tree(root: Path) -> dict[str, bytes | None]:
    """Every file (its bytes) and folder (None) under root."""
    return {p.relative_to(root).as_posix(): (p.read_bytes() if p.is_file() else None)
            for p in sorted(root.rglob("*"))}


def workspace(folder: Path, database: bytes = b"db-1") -> Path:
    write(folder / "database.db", database)
    write(folder / "sparse" / "0" / "images.bin", b"images")
    write(folder / "scene.json", b"{}")
    (folder / "sparse" / "1").mkdir(parents=True)  # an empty folder is part of a workspace too
    return folder


def publish(store: Store, database: bytes = b"db-1", reuse_from=()) -> tuple[str, dict]:
    with store.staging(PID) as scratch:
        expected = tree(workspace(scratch / "ws", database))
        return store.publish(PID, scratch / "ws", reuse_from), expected


def test_a_file_put_is_fetched_streamed_and_removed(any_store, tmp_path):
    key = image_key(PID, "a.jpg")
    big = os.urandom(3 * (1 << 20) + 17)  # several chunks of a stream
    any_store.put(key, write(tmp_path / "src" / "a.jpg", big))
    assert any_store.exists(key) and not any_store.exists(image_key(PID, "b.jpg"))
    any_store.fetch(key, tmp_path / "out" / "a.jpg")
    assert (tmp_path / "out" / "a.jpg").read_bytes() == big
    assert blob_bytes(any_store, key) == big
    any_store.put(key, write(tmp_path / "src2" / "a.jpg", b"replaced"))
    assert blob_bytes(any_store, key) == b"replaced"
    any_store.remove(key)
    assert not any_store.exists(key)


def test_a_store_that_answers_passes_its_check_and_the_probe_is_no_project_file(any_store):
    """Readiness writes a probe; it must not look like a project file to the reconciler."""
    any_store.prepare()  # as the API's start does
    any_store.check()
    any_store.check()  # again: the same probe, nothing piles up
    assert any_store.children("projects") == []


def test_a_missing_file_is_file_not_found(any_store, tmp_path):
    with pytest.raises(FileNotFoundError):
        any_store.fetch(image_key(PID, "none.jpg"), tmp_path / "x")
    with pytest.raises(FileNotFoundError):
        any_store.blob(thumb_key(PID, 1))


def test_children_are_one_level_and_changed_gives_times(any_store, tmp_path):
    any_store.put(image_key(PID, "a.jpg"), write(tmp_path / "a", b"a"))
    any_store.put(thumb_key(PID, 3), write(tmp_path / "t", b"t"))
    published, _ = publish(any_store)
    assert set(any_store.children(f"projects/{PID}")) >= {"images", "thumbs", "versions"}
    assert any_store.children(f"projects/{PID}/images") == ["a.jpg"]
    assert any_store.children(f"projects/{PID}/versions") == [published.rsplit("/", 1)[1]]
    assert any_store.children(f"projects/{PID + 1}") == []
    for key in (image_key(PID, "a.jpg"), published, f"projects/{PID}"):
        assert abs(any_store.changed(key) - os.path.getmtime(tmp_path)) < 600, key
    assert any_store.changed(image_key(PID, "b.jpg")) is None
    assert any_store.changed(f"projects/{PID + 1}") is None


def test_s3_children_list_one_level_page_by_page(moto_server, monkeypatch, temp_dir, tmp_path):
    """Only the level asked for is listed (a delimiter), across pages: the reconciler's look at
    `projects` costs one entry per project, not one per object of the bucket."""
    from guided_sfm.storage import s3
    from tests.s3server import CREDENTIALS

    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    store = S3Store.from_url(f"s3://{moto_server.new_bucket()}/pre", moto_server.url)
    names = [f"{i}.jpg" for i in range(5)]
    for name in names:
        store.put(image_key(PID, name), write(tmp_path / name, b"x"))
    publish(store)
    store.put(image_key(PID + 1, "a.jpg"), write(tmp_path / "other", b"x"))
    # a folder marker (an empty object named like the folder, as consoles make) names no child
    store.client.put_object(Bucket=store.bucket, Key=store._key(f"projects/{PID + 1}/images") + "/", Body=b"")
    listed = []
    store.client.meta.events.register("after-call.s3.ListObjectsV2", lambda parsed, **_: listed.append(
        len(parsed.get("Contents", [])) + len(parsed.get("CommonPrefixes", []))))
    monkeypatch.setattr(s3, "PAGE", 2)
    assert store.children("projects") == [str(PID), str(PID + 1)]
    assert sum(listed) == 2
    listed.clear()
    assert store.children(f"projects/{PID}/images") == sorted(names)
    assert sum(listed) == len(names) and len(listed) == 3  # three pages of two
    assert store.children(f"projects/{PID + 1}/images") == ["a.jpg"]


def test_a_published_version_reads_back_as_it_was_staged(any_store):
    version, expected = publish(any_store)
    assert version.startswith(f"projects/{PID}/versions/")
    with any_store.reading(version) as root:
        assert tree(root) == expected
    with any_store.reading(version, only=("database.db",)) as root:
        assert (root / "database.db").read_bytes() == b"db-1"
        assert not (root / "sparse" / "0" / "images.bin").exists() or isinstance(any_store, ArtifactStore)


def test_every_publish_gets_a_new_key_and_old_versions_stay(any_store):
    first, _ = publish(any_store, b"db-1")
    second, _ = publish(any_store, b"db-2", reuse_from=(first,))
    assert first != second
    with any_store.reading(first) as a, any_store.reading(second) as b:
        assert (a / "database.db").read_bytes() == b"db-1" and (b / "database.db").read_bytes() == b"db-2"
        assert (a / "scene.json").read_bytes() == (b / "scene.json").read_bytes() == b"{}"


def test_a_restored_copy_is_a_new_version_with_the_same_content(any_store):
    first, expected = publish(any_store)
    copy = any_store.copy_version(PID, first)
    assert copy != first
    with any_store.reading(copy) as root:
        assert tree(root) == expected
    with any_store.reading(first) as root:
        assert tree(root) == expected


def test_one_member_of_a_version_is_fetched_or_reported_missing(any_store, tmp_path):
    version, _ = publish(any_store)
    assert any_store.fetch_member(version, "scene.json", tmp_path / "got" / "scene.json")
    assert (tmp_path / "got" / "scene.json").read_bytes() == b"{}"
    assert not any_store.fetch_member(version, "vocab_tree.bin", tmp_path / "got" / "tree")
    assert not (tmp_path / "got" / "tree").exists()


def test_images_for_a_job_hold_the_named_images(any_store, tmp_path):
    for name in ("a.jpg", "b.jpg", "c.jpg"):
        any_store.put(image_key(PID, name), write(tmp_path / "src" / name, name.encode()))
    with any_store.staging(PID, prefix="job-1-") as scratch:
        folder = any_store.images_for(PID, ["a.jpg", "c.jpg"], scratch)
        assert (folder / "a.jpg").read_bytes() == b"a.jpg" and (folder / "c.jpg").read_bytes() == b"c.jpg"


def test_scratch_is_emptied_after_the_block_even_on_error(any_store, temp_dir):
    with pytest.raises(RuntimeError), any_store.staging(PID, prefix="job-1-") as scratch:
        write(scratch / "big.bin", b"x" * 1000)
        if isinstance(any_store, S3Store):  # S3 scratch lives under the process's TMPDIR
            assert scratch.is_relative_to(temp_dir)
        raise RuntimeError("the job crashed")
    assert not scratch.exists()


def test_a_publish_that_crashes_leaves_no_readable_version(any_store, monkeypatch):
    """The crash is injected where each backend makes the version visible: the data dir's rename,
    S3's upload of the second file (the manifest, written last, never is)."""
    good, _ = publish(any_store)
    s3 = isinstance(any_store, S3Store)
    target, name = (any_store, "put") if s3 else (os, "replace")
    original, calls = getattr(target, name), []

    def crash(*args):
        calls.append(args)
        if len(calls) >= (2 if s3 else 1):
            raise OSError("the worker died here")
        return original(*args)

    monkeypatch.setattr(target, name, crash)
    with pytest.raises(OSError, match="died"):
        publish(any_store, b"db-2")
    monkeypatch.undo()
    assert len(calls) == (2 if s3 else 1)
    versions = any_store.children(f"projects/{PID}/versions")
    assert len(versions) == (2 if s3 else 1)  # S3: one file of the half version is there, unread
    for half in (f"projects/{PID}/versions/{name}" for name in versions):
        if half != good:
            with pytest.raises(FileNotFoundError), any_store.reading(half):
                pass
    with any_store.reading(good) as root:
        assert (root / "database.db").read_bytes() == b"db-1"


def test_deleting_a_project_removes_every_key(any_store, tmp_path):
    any_store.put(image_key(PID, "a.jpg"), write(tmp_path / "a", b"a"))
    publish(any_store)
    any_store.put(image_key(PID + 1, "a.jpg"), write(tmp_path / "b", b"b"))
    any_store.delete_project(PID)
    assert any_store.children(f"projects/{PID}") == []
    assert any_store.exists(image_key(PID + 1, "a.jpg"))  # projects/8 is not under projects/7


def test_stale_scratch_of_a_dead_process_is_cleared(any_store, temp_dir):
    with any_store.staging(PID, prefix="job-1-") as live:
        if isinstance(any_store, S3Store):
            dead = any_store.scratch_root / "job-2-p999999999-abc"  # no such pid
            write(dead / "database.db", b"x")
            assert any_store.clear_stale_scratch() == 1
            assert not dead.exists()
        else:
            assert any_store.clear_stale_scratch() == 0  # data-dir staging is the reconciler's
        assert live.is_dir()  # a live process's scratch stays


def test_s3_shares_unchanged_files_and_writes_the_manifest_last(moto_server, monkeypatch, temp_dir):
    from tests.s3server import CREDENTIALS

    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    store = S3Store.from_url(f"s3://{moto_server.new_bucket()}", moto_server.url)
    written = []
    for method in ("put", "put_bytes"):
        original = getattr(store, method)
        monkeypatch.setattr(store, method, lambda key, what, original=original: (written.append(key),
                                                                                  original(key, what)))
    first, _ = publish(store, b"db-1")
    assert written[-1] == f"{first}/manifest.json" and len(written) == 4  # 3 files, then the manifest
    written.clear()
    second, _ = publish(store, b"db-2", reuse_from=(first,))
    assert written == [f"{second}/files/database.db", f"{second}/manifest.json"]  # only what changed
    with store.reading(second) as root:
        assert (root / "sparse" / "0" / "images.bin").read_bytes() == b"images"
