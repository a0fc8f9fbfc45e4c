"""What the API reads of a published version is the same on both backends: the files a reader
fetches from S3 are all the files its answer depends on."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from types import SimpleNamespace

from guided_sfm.actions import version_data
from guided_sfm.core.workspace import Workspace

PID = 7


def applied_workspace(folder: Path) -> Path:
    """A round's workspace: two cameras placed, one of them joined as part of a sub-model."""
    folder.mkdir(parents=True)
    with sqlite3.connect(folder / "database.db") as conn:
        conn.execute("CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT)")
        conn.executemany("INSERT INTO images VALUES (?, ?)", [(1, "a.jpg"), (2, "b.jpg"), (3, "c.jpg")])
    conn.close()
    cameras = [{"image_id": i, "x": 0.0, "y": 0.0, "yaw_deg": 0.0} for i in (1, 2)]
    (folder / "edits.json").write_text(json.dumps({"cameras": cameras}))
    (folder / "joined.json").write_text(json.dumps([2]))
    return folder


def test_edited_images_of_a_version_exclude_joined_ones_on_every_backend(any_store, tmp_path):
    staged = applied_workspace(tmp_path / "staged")
    assert Workspace(staged).touched_names() == {"a.jpg"}  # the local truth
    version = SimpleNamespace(path=any_store.publish(PID, staged))
    assert version_data._edited(any_store, version) == {"a.jpg"}
