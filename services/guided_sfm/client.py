"""A Python client of the REST contract v1 (design.md), for scripts and CI:

    from guided_sfm.client import Client
    with Client("http://127.0.0.1:8000", token=os.environ["GUIDED_SFM_TOKEN"]) as api:
        pid = api.create_project("office")["id"]
        api.upload(pid, sorted(Path("images").glob("*.jpg")))
        job = api.wait(api.reconstruct(pid)["id"], progress=print)

Methods return the contract's JSON as dicts and lists; a refused request raises ApiError with the
server's status and detail; a job that fails or is cancelled raises JobFailed from wait().
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import httpx

Json = dict[str, Any]
ENDED = ("succeeded", "failed", "cancelled")
UPLOAD_BATCH = 20  # files per request: each request is all-or-nothing, so a bad file costs one batch
UPLOAD_BATCH_MB = 100  # bytes per request, far under the server's cap (1,024 MB by default); a 413 halves it
UPLOAD_RETRIES = 3  # a batch lost on the network or to a 5xx is sent again (the server skips what it has)


class ApiError(Exception):
    """The server refused a request: `status` and the server's `detail`."""

    def __init__(self, method: str, path: str, status: int, detail: str) -> None:
        super().__init__(f"{method} {path}: {status} {detail}")
        self.status, self.detail = status, detail


class JobFailed(Exception):
    """A job ended failed or cancelled; `job` is its last state."""

    def __init__(self, job: Json) -> None:
        super().__init__(f"job {job['id']} {job['state']}: {job.get('error') or job.get('message')}")
        self.job = job


class Client:
    """One server, one bearer token (a personal access token, or a session token from sign_in)."""

    def __init__(self, url: str, token: str | None = None, timeout: float = 60.0,
                 transport: httpx.BaseTransport | None = None) -> None:
        self.http = httpx.Client(base_url=url.rstrip("/") + "/api/v1", timeout=timeout,
                                 transport=transport)
        if token:
            self.http.headers["Authorization"] = f"Bearer {token}"

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.http.close()

    def request(self, method: str, path: str, **kwargs: Any) -> Any:
        """The decoded JSON answer (None for 204); ApiError for any 4xx/5xx."""
        response = self.http.request(method, path, **kwargs)
        if response.is_error:
            try:
                detail = response.json().get("detail", response.text)
            except ValueError:
                detail = response.text
            raise ApiError(method, path, response.status_code, str(detail))
        if response.status_code == 204 or not response.content:
            return None
        kind = response.headers.get("content-type", "")
        return response.json() if kind.startswith("application/json") else response.content

    # accounts and tokens
    def sign_up(self, username: str, password: str) -> Json:
        return self.request("POST", "/users", json={"username": username, "password": password})

    def sign_in(self, username: str, password: str) -> str:
        """A session token, which this client then sends."""
        answer = self.request("POST", "/auth/token", data={"username": username, "password": password})
        self.http.headers["Authorization"] = f"Bearer {answer['access_token']}"
        return answer["access_token"]

    def create_token(self, name: str, scope: str = "write", projects: Sequence[int] | None = None,
                     expires_days: int | None = None) -> Json:
        body = {"name": name, "scope": scope, "projects": list(projects) if projects else None,
                "expires_days": expires_days}
        return self.request("POST", "/tokens", json=body)

    def tokens(self) -> list[Json]:
        return self.request("GET", "/tokens")

    def revoke_token(self, token_id: int) -> None:
        self.request("DELETE", f"/tokens/{token_id}")

    # projects and images
    def projects(self) -> list[Json]:
        return self.request("GET", "/projects")

    def create_project(self, name: str, description: str = "") -> Json:
        return self.request("POST", "/projects", json={"name": name, "description": description})

    def delete_project(self, pid: int) -> None:
        self.request("DELETE", f"/projects/{pid}")

    def images(self, pid: int) -> list[Json]:
        return self.request("GET", f"/projects/{pid}/images")

    def upload(self, pid: int, files: Iterable[Path], batch: int = UPLOAD_BATCH,
               progress: Callable[[int, int], None] | None = None,
               batch_mb: float = UPLOAD_BATCH_MB, retries: int = UPLOAD_RETRIES) -> list[Json]:
        """Upload in batches of at most `batch` files and `batch_mb` MB; `progress(done, total)`
        (files) after each. Resumable: files the project already has (same name and SHA-256) are
        not sent again but listed as `already_uploaded`; a batch that fails on the network or with
        a 5xx is sent again (the server recognises what it stored); a 413 splits the batch."""
        paths = [Path(f) for f in files]
        known = {image["name"]: image for image in self.images(pid)}
        created = [{**known[p.name], "already_uploaded": True} for p in paths if _has(known, p)]
        todo = [p for p in paths if not _has(known, p)]
        done = len(created)
        if progress and done:
            progress(done, len(paths))
        for chunk in _batches(todo, batch, int(batch_mb * (1 << 20))):
            created += self._send_batch(pid, chunk, retries)
            done += len(chunk)
            if progress:
                progress(done, len(paths))
        return created

    def _send_batch(self, pid: int, chunk: list[Path], retries: int) -> list[Json]:
        for attempt in range(retries + 1):
            try:
                return self._post_files(pid, chunk)
            except ApiError as exc:
                if exc.status == 413 and len(chunk) > 1:  # over the server's cap: halves
                    half = len(chunk) // 2
                    return self._send_batch(pid, chunk[:half], retries) + \
                        self._send_batch(pid, chunk[half:], retries)
                if exc.status < 500 or attempt == retries:
                    raise
            except httpx.TransportError:
                if attempt == retries:
                    raise
            time.sleep(min(2.0 ** attempt, 10.0))
        raise AssertionError("unreachable")

    def _post_files(self, pid: int, chunk: list[Path]) -> list[Json]:
        handles = [path.open("rb") for path in chunk]
        try:
            parts = [("files", (path.name, handle)) for path, handle in zip(chunk, handles, strict=True)]
            return self.request("POST", f"/projects/{pid}/images", files=parts)
        finally:
            for handle in handles:
                handle.close()

    # jobs
    def reconstruct(self, pid: int, **options: Any) -> Json:
        """Queue a reconstruction (options: camera_model, matcher, mapper, max_image_size); the job."""
        return self.request("POST", f"/projects/{pid}/reconstruct", json=options)

    def job(self, job_id: int) -> Json:
        return self.request("GET", f"/jobs/{job_id}")

    def jobs(self, pid: int) -> list[Json]:
        return self.request("GET", f"/projects/{pid}/jobs")

    def cancel(self, job_id: int) -> Json:
        return self.request("POST", f"/jobs/{job_id}/cancel")

    def wait(self, job_id: int, progress: Callable[[Json], None] | None = None, poll: float = 1.0,
             timeout: float | None = None) -> Json:
        """The job once it succeeded; JobFailed if it failed or was cancelled, TimeoutError after
        `timeout` seconds. `progress(job)` is called on every poll."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            job = self.job(job_id)
            if progress:
                progress(job)
            if job["state"] == "succeeded":
                return job
            if job["state"] in ENDED:
                raise JobFailed(job)
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"job {job_id} is still {job['state']} after {timeout} s")
            time.sleep(poll)

    # versions
    def versions(self, pid: int) -> list[Json]:
        return self.request("GET", f"/projects/{pid}/versions")

    def head(self, pid: int) -> int | None:
        return self.request("GET", f"/projects/{pid}")["head_version_id"]

    def scene(self, pid: int, vid: int) -> Json:
        return self.request("GET", f"/projects/{pid}/versions/{vid}/scene")

    def pairs(self, pid: int, vid: int, image_id: int | None = None, order: str | None = None,
              limit: int | None = None, offset: int | None = None) -> list[Json]:
        """Verified pairs; `order="inliers"` lists the most inliers first; limit/offset page."""
        params = {key: value for key, value in (("image_id", image_id), ("order", order),
                                                ("limit", limit), ("offset", offset)) if value is not None}
        return self.request("GET", f"/projects/{pid}/versions/{vid}/pairs", params=params or None)

    def restore(self, pid: int, vid: int) -> Json:
        return self.request("POST", f"/projects/{pid}/versions/{vid}/restore")

    def export(self, pid: int, vid: int, fmt: str = "colmap") -> bytes:
        return self.request("GET", f"/projects/{pid}/versions/{vid}/export", params={"format": fmt})

    # edit sets
    def edit_sets(self, pid: int) -> list[Json]:
        return self.request("GET", f"/projects/{pid}/edits")

    def create_edit_set(self, pid: int, base_version_id: int, **body: Any) -> Json:
        """body: cameras, delete_pairs, flags, rule, tolerances (REST image ids)."""
        body = {"base_version_id": base_version_id, **body}
        return self.request("POST", f"/projects/{pid}/edits", json=body)

    def edit_set(self, pid: int, eid: int) -> Json:
        return self.request("GET", f"/projects/{pid}/edits/{eid}")

    def update_edit_set(self, pid: int, eid: int, revision: int, body: Json) -> Json:
        """Save over revision `revision` (409 from the server if someone saved since)."""
        return self.request("PUT", f"/projects/{pid}/edits/{eid}", json=body,
                            headers={"If-Match": f'"{revision}"'})

    def preview(self, pid: int, eid: int) -> Json:
        return self.request("GET", f"/projects/{pid}/edits/{eid}/preview")

    def apply(self, pid: int, eid: int, remap: bool = True) -> Json:
        """Queue the edit set's apply (prune, and map again when `remap`); the job."""
        return self.request("POST", f"/projects/{pid}/edits/{eid}/apply", json={"remap": remap})


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as source:
        while chunk := source.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _has(known: dict[str, Json], path: Path) -> bool:
    """Whether the project holds this file already: same name and bytes (a name with other bytes
    is sent, and the server's 409 names it)."""
    image = known.get(path.name)
    return image is not None and image.get("sha256") == file_sha256(path)


def _batches(paths: list[Path], most: int, most_bytes: int) -> Iterator[list[Path]]:
    """Consecutive batches of at most `most` files and `most_bytes` (a larger file goes alone)."""
    chunk: list[Path] = []
    size = 0
    for path in paths:
        length = path.stat().st_size
        if chunk and (len(chunk) >= most or size + length > most_bytes):
            yield chunk
            chunk, size = [], 0
        chunk.append(path)
        size += length
    if chunk:
        yield chunk


def with_image_ids(edits: Json, images: list[Json]) -> Json:
    """An edit set written with image names (the CLI's edits.json) in REST image ids; a number
    given as `image_id` is taken as a REST id already."""
    ids = {image["name"]: image["id"] for image in images}

    def rest_id(item: Any) -> int:
        if isinstance(item, str):
            if item not in ids:
                raise ValueError(f"no image named {item!r} in the project")
            return ids[item]
        return int(item)

    cameras = [{**{k: v for k, v in cam.items() if k != "name"},
                "image_id": rest_id(cam.get("name", cam.get("image_id")))}
               for cam in edits.get("cameras", [])]
    pairs = [[rest_id(a), rest_id(b)] for a, b in edits.get("delete_pairs", [])]
    body = {**edits, "cameras": cameras, "delete_pairs": pairs}
    if "flags" in edits:
        body["flags"] = [rest_id(item) for item in edits["flags"]]
    return body
