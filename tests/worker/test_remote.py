"""guided_sfm.client and `guided-sfm remote` against a real `guided-sfm serve` (API + worker
processes, embedded default), with a personal access token: the whole loop."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from guided_sfm.client import ApiError, Client
from tests.factories import PASSWORD
from tests.worker.test_serve import free_port

START_TIMEOUT = 120.0  # migrations and imports on a loaded 2-core machine


@contextmanager
def serving(tmp_path: Path, **settings: str) -> Iterator[str]:
    """The URL of a `guided-sfm serve` of the caller's own (its env without GUIDED_SFM_* but these
    settings), stopped with SIGTERM after."""
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("GUIDED_SFM_")} | settings
    with open(tmp_path / "serve.log", "wb") as log:
        serve = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "serve", "--port", str(port),
                                  "--data-dir", str(tmp_path / "data")], env=env,
                                 stdout=subprocess.DEVNULL, stderr=log)
    url = f"http://127.0.0.1:{port}"
    started = time.monotonic()
    while time.monotonic() - started < START_TIMEOUT:
        try:
            if httpx.get(url + "/api/v1/health", timeout=2).status_code == 200:
                break
        except httpx.HTTPError:
            time.sleep(0.3)
    else:
        serve.kill()
        raise AssertionError("serve did not answer:\n" + (tmp_path / "serve.log").read_text()[-2000:])
    print(f"serve answered after {time.monotonic() - started:.1f} s")
    try:
        yield url
    finally:
        serve.send_signal(signal.SIGTERM)
        serve.wait(timeout=60)


@pytest.fixture
def served(tmp_path):
    with serving(tmp_path) as url:
        yield url


def remote(url: str, token: str, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "GUIDED_SFM_TOKEN": token}
    return subprocess.run([sys.executable, "-m", "guided_sfm.cli", "remote", "--url", url, *args],
                          env=env, capture_output=True, text=True, timeout=900)


def ok(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


@pytest.mark.slow
def test_remote_cli_runs_the_loop_with_an_access_token(served, tiny_images, tmp_path):
    with Client(served) as api:
        api.sign_up("ci", PASSWORD)
        api.sign_in("ci", PASSWORD)
        token = api.create_token("nightly", "write")["token"]
    pid = json.loads(ok(remote(served, token, "create", "tiny", "--json")))["id"]
    uploaded = json.loads(ok(remote(served, token, "upload", str(pid), str(tiny_images / "images"),
                                    "--batch", "5", "--json")))
    assert uploaded == {"uploaded": len(list((tiny_images / "images").iterdir()))}
    # 0: COLMAP's own size (3200); the tiny sample's 640x480 images get the same features
    job = json.loads(ok(remote(served, token, "reconstruct", str(pid), "--max-image-size", "0", "--json")))
    assert job["state"] == "succeeded" and job["version_id"] is not None
    assert job["message"].endswith(", max image size 3200)"), job["message"]
    scene = json.loads(ok(remote(served, token, "scene", str(pid))))
    camera = next(c for c in scene["cameras"] if c["registered"])
    with Client(served, token) as api:
        before = {tuple(p) for p in _pairs(api, pid, job["version_id"])}
    far = {"cameras": [{"name": camera["name"], "x": camera["x"] + 1000.0, "y": camera["y"],
                        "yaw_deg": camera["yaw_deg"]}]}
    (tmp_path / "edits.json").write_text(json.dumps(far))
    dry = json.loads(ok(remote(served, token, "prune", str(pid), str(tmp_path / "edits.json"),
                               "--dry-run", "--json")))
    assert dry["pairs_to_delete"] and "version" not in dry
    with Client(served, token) as api:
        assert api.head(pid) == job["version_id"]  # a dry run changes nothing
    mapped = json.loads(ok(remote(served, token, "map", str(pid), str(dry["edit_set"]), "--json")))
    assert mapped["state"] == "succeeded"
    with Client(served, token) as api:
        after = {tuple(p) for p in _pairs(api, pid, mapped["version_id"])}
    assert after == before - {tuple(p) for p in dry["pairs_to_delete"]}
    ok(remote(served, token, "export", str(pid), str(tmp_path / "model.ply"), "--format", "ply"))
    assert (tmp_path / "model.ply").read_bytes().startswith(b"ply")


def _pairs(api: Client, pid: int, vid: int) -> list[list[int]]:
    return [sorted((p["image_id1"], p["image_id2"])) for p in api.pairs(pid, vid)]


def test_remote_cli_says_why_a_token_is_refused(served):
    result = remote(served, "gsfm_not-a-token", "projects")
    assert result.returncode == 1
    assert "401" in result.stderr and "unknown or revoked" in result.stderr
    with Client(served, "gsfm_not-a-token") as api, pytest.raises(ApiError) as refused:
        api.projects()
    assert refused.value.status == 401
