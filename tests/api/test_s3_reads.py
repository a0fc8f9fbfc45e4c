"""A version answers the same from either store: what the API reads of a version published to
S3 (moto's server over HTTP) equals what it reads of the same version in the data dir. Catches a
file the S3 reader forgets to fetch (version_data.READ and the other `only=` lists)."""

import tempfile
from types import SimpleNamespace

import pytest

from guided_sfm.actions import version_data
from guided_sfm.db.models import EditSetRow, Version
from guided_sfm.storage.s3 import S3Store
from tests.s3server import CREDENTIALS


@pytest.fixture
def on_s3(reconstructed, session, store, moto_server, monkeypatch, tmp_path):
    """(the version in the data dir, the same files published to S3, the S3 store)."""
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR: the store's scratch goes there
    s3 = S3Store.from_url(f"s3://{moto_server.new_bucket()}/artifacts", moto_server.url)
    local = session.get(Version, reconstructed.vid)
    key = s3.publish(local.project_id, store.version_dir(local.path))
    return local, SimpleNamespace(id=local.id, project_id=local.project_id, path=key, parent_id=None), s3


def test_scene_pairs_and_suspects_are_the_same_from_s3(on_s3, session, store):
    local, remote, s3 = on_s3
    assert version_data.scene(session, s3, remote) == version_data.scene(session, store, local)
    assert version_data.scene(session, s3, remote, 40) == version_data.scene(session, store, local, 40)
    assert version_data.pairs(session, s3, remote, None) == version_data.pairs(session, store, local, None)
    found = version_data._suspects(session, s3, remote)
    assert found == version_data._suspects(session, store, local) and found["suspects"]


def test_a_preview_is_the_same_from_s3(on_s3, session, store, reconstructed):
    local, remote, s3 = on_s3
    run = next(r for r in version_data._suspects(session, store, local)["runs"] if r["proposal"])
    row = EditSetRow(project_id=local.project_id, base_version_id=local.id,
                     body={"cameras": run["proposal"]["cameras"]})
    expected = version_data.preview(session, store, row, local)
    assert expected["pairs_to_delete"]  # a preview that deletes something, or the check is empty
    assert version_data.preview(session, s3, row, remote) == expected


def test_a_preview_or_compare_asked_again_reads_nothing_from_s3(on_s3, session, store):
    """A version never changes: the same preview (same edit set body) or compare again is answered
    from memory, without a request to S3; another body is computed afresh."""
    local, remote, s3 = on_s3
    calls = []
    s3.client.meta.events.register("after-call.s3", lambda **_: calls.append(1))
    run = next(r for r in version_data._suspects(session, store, local)["runs"] if r["proposal"])
    row = EditSetRow(project_id=local.project_id, base_version_id=local.id,
                     body={"cameras": run["proposal"]["cameras"]})
    first = version_data.preview(session, s3, row, remote)
    assert calls
    calls.clear()
    assert version_data.preview(session, s3, row, remote) == first and not calls
    pair = first["pairs_to_delete"][0]
    other = EditSetRow(project_id=local.project_id, base_version_id=local.id, body={"delete_pairs": [pair]})
    assert version_data.preview(session, s3, other, remote)["pairs_to_delete"] == [pair] and calls
    calls.clear()
    compared = version_data.compare(session, s3, remote, remote)
    assert compared["cameras"] and calls
    calls.clear()
    assert version_data.compare(session, s3, remote, remote) == compared and not calls
