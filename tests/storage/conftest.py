"""One store fixture, two backends: every contract test runs on the data dir and on S3 (moto's
server over HTTP)."""

import tempfile

import pytest

from guided_sfm.storage import ArtifactStore
from guided_sfm.storage.s3 import S3Store
from tests.s3server import CREDENTIALS


@pytest.fixture
def temp_dir(tmp_path, monkeypatch):
    """The process's TMPDIR for this test (where S3 scratch must live)."""
    path = tmp_path / "tmpdir"
    path.mkdir()
    monkeypatch.setenv("TMPDIR", str(path))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR
    return path


@pytest.fixture(params=["data_dir", "s3"])
def any_store(request, tmp_path, temp_dir, monkeypatch):
    if request.param == "data_dir":
        return ArtifactStore(tmp_path / "artifacts")
    server = request.getfixturevalue("moto_server")
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    return S3Store.from_url(f"s3://{server.new_bucket()}/some/prefix", server.url)
