"""Disk full during an upload (the data dir on a small tmpfs, where the machine lets the test mount
one): 507 naming it, nothing stored, and the next upload that fits goes through."""

from __future__ import annotations

import os
import random
import subprocess

import pytest

from tests.conftest import create_database
from tests.factories import jpeg_bytes, zip_bytes
from tests.faults.conftest import login
from tests.faults.live_api import LiveApi, service_env
from tests.faults.test_sqlite_writes import _multipart


@pytest.fixture
def small_data_dir(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=6m", "tmpfs", str(data)],
                             capture_output=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({mounted.stderr.decode().strip()[:100]})")
    yield data
    subprocess.run(["umount", "-l", str(data)], check=False)


def noise_jpeg(seed: int) -> bytes:
    """An incompressible JPEG of about 1 MB."""
    import io

    import PIL.Image

    rng = random.Random(seed)
    img = PIL.Image.frombytes("RGB", (700, 500), bytes(rng.getrandbits(8) for _ in range(700 * 500 * 3)))
    buffer = io.BytesIO()
    img.save(buffer, "JPEG", quality=98)
    return buffer.getvalue()


def test_an_upload_that_fills_the_disk_is_507_and_stores_nothing(tmp_path, small_data_dir):
    url, drop = create_database(tmp_path)  # the database outside the full disk
    api = LiveApi(service_env(small_data_dir, url, broker_url="memory://"), tmp_path / "api.log").start()
    try:
        headers = login(api, "ops")
        pid = api.request("POST", "/api/v1/projects", {"name": "full"}, headers)[1]["id"]
        archive = zip_bytes({f"n{i}.jpg": noise_jpeg(i) for i in range(8)})
        body, extra = _multipart("many.zip", archive)
        status, answer, _ = api.request("POST", f"/api/v1/projects/{pid}/images", data=body,
                                        headers={**headers, **extra})
        assert status == 507 and "storage is full" in answer["detail"], answer
        project = small_data_dir / "artifacts" / "projects" / str(pid)
        leftovers = [p for p in project.rglob("*") if p.is_file()] if project.exists() else []
        assert leftovers == []
        assert api.request("GET", f"/api/v1/projects/{pid}/images", headers=headers)[1] == []
        body, extra = _multipart("small.jpg", jpeg_bytes())
        status, answer, _ = api.request("POST", f"/api/v1/projects/{pid}/images", data=body,
                                        headers={**headers, **extra})
        assert status == 201, answer
        assert os.listdir(project / "images") == ["small.jpg"]
    finally:
        api.kill()
        drop()
