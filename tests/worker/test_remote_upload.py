"""Batched, resumable uploads (issue 22): guided_sfm.client and `guided-sfm remote upload`
against a real `guided-sfm serve` whose upload cap (1 MB) is smaller than the photos together."""

from __future__ import annotations

import io
import json

import httpx
import numpy as np
import PIL.Image
import pytest

from guided_sfm.client import Client
from tests.factories import PASSWORD
from tests.worker.test_remote import ok, remote, serving

CAP_MB = 1


@pytest.fixture
def capped(tmp_path):
    """A `guided-sfm serve` of this test's own with GUIDED_SFM_MAX_UPLOAD_MB=1."""
    with serving(tmp_path, GUIDED_SFM_MAX_UPLOAD_MB=str(CAP_MB)) as url:
        yield url


def photos(folder, count: int) -> list:
    """Noise JPEGs of ~0.4 MB each (noise does not compress): together several times the cap."""
    folder.mkdir()
    rng = np.random.default_rng(0)
    paths = []
    for i in range(count):
        buffer = io.BytesIO()
        PIL.Image.fromarray(rng.integers(0, 255, (560, 560, 3), dtype=np.uint8)).save(buffer, "JPEG",
                                                                                     quality=95)
        paths.append(folder / f"{i:03d}.jpg")
        paths[-1].write_bytes(buffer.getvalue())
    return paths


class LosesFirstAnswer(httpx.HTTPTransport):
    """Sends every request; the first upload the server accepts is answered, then the answer is
    lost (a read timeout), as on a flaky link. Logs (status, body bytes) of each upload request."""

    def __init__(self) -> None:
        super().__init__()
        self.uploads: list[tuple[int, int]] = []
        self.lost = False

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        response = super().handle_request(request)
        if request.method == "POST" and request.url.path.endswith("/images"):
            response.read()
            self.uploads.append((response.status_code, int(request.headers["content-length"])))
            if response.status_code == 201 and not self.lost:
                self.lost = True
                raise httpx.ReadTimeout("the answer was lost", request=request)
        return response


def test_uploads_batch_under_the_cap_and_resume_without_duplicates(capped, tmp_path):
    files = photos(tmp_path / "photos", 8)
    assert sum(f.stat().st_size for f in files) > 2 * (CAP_MB << 20)
    with Client(capped) as api:
        api.sign_up("batch", PASSWORD)
        token = api.sign_in("batch", PASSWORD)
    transport = LosesFirstAnswer()
    with Client(capped, token, transport=transport) as api:
        pid = api.create_project("many")["id"]
        seen = []
        created = api.upload(pid, files, batch=20, batch_mb=5, progress=lambda d, t: seen.append((d, t)))
        assert sorted(image["name"] for image in created) == [f.name for f in files]
        stored = api.images(pid)
        assert sorted(image["name"] for image in stored) == [f.name for f in files]  # no duplicate
        statuses = [status for status, _ in transport.uploads]
        assert 413 in statuses  # 5 MB batches are over this server's cap: they were split
        assert all(size <= (CAP_MB + 1) << 20 for status, size in transport.uploads if status == 201)
        assert any(image.get("already_uploaded") for image in created)  # the lost batch, sent again
        assert seen[-1] == (8, 8)
        posts = len(transport.uploads)
        again = api.upload(pid, files, batch_mb=0.5)  # resumed: nothing left to send
        assert len(transport.uploads) == posts and all(i["already_uploaded"] for i in again)
    extra = photos(tmp_path / "more", 1)[0].rename(tmp_path / "photos" / "new.jpg")
    result = json.loads(ok(remote(capped, token, "upload", str(pid), str(tmp_path / "photos"),
                                  "--batch-mb", "0.5", "--json")))
    assert result == {"uploaded": 1, "already_uploaded": 8}
    with Client(capped, token) as api:
        assert len(api.images(pid)) == 9 and extra.name in {i["name"] for i in api.images(pid)}
