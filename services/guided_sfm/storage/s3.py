"""The S3 backend (any S3-compatible server: AWS, MinIO, moto). A version is a set of objects under
`versions/{vid}/files/` and a manifest `versions/{vid}/manifest.json` naming each file's key, size
and SHA-256; the manifest is written last, so a version exists once its manifest does and a job that
dies before it leaves objects no reader looks at (the reconciler collects them). Work happens in a
scratch dir under the process's temp dir (TMPDIR), emptied when the job or request ends."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import tempfile
import time
import uuid
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import urlsplit

import boto3
from boto3.exceptions import Boto3Error
from botocore.config import Config
from botocore.exceptions import BotoCoreError, ClientError, ParamValidationError

from guided_sfm.storage.base import (
    Blob,
    Store,
    StoreUnavailable,
    UnpublishedVersion,
    image_key,
    project_prefix,
)

MANIFEST = "manifest.json"
SCRATCH = "guided-sfm-scratch"  # under the temp dir; one folder per job or request, named by pid
TRANSFERS = 8  # parallel downloads when a job fetches its inputs
CHUNK = 1 << 20  # bytes per chunk when the API streams a file
PAGE = 1000  # keys per listing request (S3's most)
# a request waits this long for an endpoint that does not answer (to connect; then for each read:
# botocore's default is 60 s), and is retried this often after its first try, 4 tries in all
# (botocore's "standard" retries back off between tries; measured: 4 sends to a hung endpoint):
# an outage costs a request seconds (a hung endpoint under a minute), not minutes
CONNECT_SECONDS, READ_SECONDS, ATTEMPTS = 5, 10, 3
# readiness writes one small object, once and briefly: a probe must answer before its caller gives up
PROBE_KEY, PROBE_SECONDS = ".guided-sfm-ready", 2  # outside projects/, which the reconciler walks
# what boto3 raises when the store, not the key, is the problem (a missing key is caught before)
UNAVAILABLE = (ClientError, BotoCoreError, Boto3Error)


def _reaching(method):
    """The method's S3 errors as StoreUnavailable (the API's 503), naming the error, not the
    endpoint."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        try:
            result = method(self, *args, **kwargs)
        except ParamValidationError:  # a call this code got wrong, not the store's state
            raise
        except UNAVAILABLE as exc:
            raise StoreUnavailable(f"artifact store unavailable ({_reason(exc)})") from exc
        self.answered_at = time.monotonic()
        return result

    return wrapper


class S3Store(Store):
    def __init__(self, client, bucket: str, prefix: str = "", scratch_root: Path | None = None,
                 probe_client=None) -> None:
        self.client, self.bucket, self.prefix = client, bucket, prefix.strip("/")
        self.scratch_root = scratch_root or Path(tempfile.gettempdir()) / SCRATCH
        self.probe_client = probe_client or client

    @classmethod
    def from_url(cls, artifacts_url: str, endpoint_url: str = "") -> S3Store:
        """s3://BUCKET/PREFIX; boto3 reads AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY and
        AWS_DEFAULT_REGION itself."""
        url = urlsplit(artifacts_url)
        endpoint = endpoint_url or None

        def client(seconds: tuple[float, float], retries: dict):
            config = Config(connect_timeout=seconds[0], read_timeout=seconds[1], retries=retries,
                            s3={"addressing_style": "path"} if endpoint else None)  # path: MinIO, moto
            return boto3.session.Session().client("s3", endpoint_url=endpoint, config=config)

        # botocore's max_attempts counts retries (one more try in all), total_max_attempts tries
        return cls(client((CONNECT_SECONDS, READ_SECONDS), {"max_attempts": ATTEMPTS, "mode": "standard"}),
                   url.netloc, url.path,
                   probe_client=client((PROBE_SECONDS, PROBE_SECONDS), {"total_max_attempts": 1}))

    def _key(self, key: str) -> str:
        return f"{self.prefix}/{key}" if self.prefix else key

    def __repr__(self) -> str:
        return f"S3Store(s3://{self.bucket}/{self.prefix})"

    # -- single files -----------------------------------------------------------------------------

    @_reaching
    def put(self, key: str, source: Path) -> None:
        self.client.upload_file(str(source), self.bucket, self._key(key))

    @_reaching
    def put_bytes(self, key: str, data: bytes) -> None:
        self.client.put_object(Bucket=self.bucket, Key=self._key(key), Body=data)

    @_reaching
    def fetch(self, key: str, target: Path) -> None:
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            self.client.download_file(self.bucket, self._key(key), str(target))
        except ClientError as exc:
            raise _missing(exc, key) from exc

    @_reaching
    def exists(self, key: str) -> bool:
        return self._head(key) is not None

    @_reaching
    def remove(self, key: str) -> None:
        keys = [self._key(key), *(k for k, _ in self._list(key + "/"))]
        for start in range(0, len(keys), 1000):  # S3's limit per request
            objects = [{"Key": k} for k in keys[start:start + 1000]]
            self.client.delete_objects(Bucket=self.bucket, Delete={"Objects": objects, "Quiet": True})

    @_reaching
    def children(self, prefix: str) -> list[str]:
        """One level, page by page: files and folders ("common prefixes") under prefix + "/"."""
        start, found = len(self._key(prefix)) + 1, set()
        for page in self._pages(prefix + "/", Delimiter="/"):
            found.update(item["Key"][start:] for item in page.get("Contents", []))
            found.update(item["Prefix"][start:].rstrip("/") for item in page.get("CommonPrefixes", []))
        found.discard("")  # a folder marker (the object prefix + "/") is the folder itself
        return sorted(found)

    @_reaching
    def changed(self, key: str) -> float | None:
        """A folder's newest object (everything under it is listed), else the file's own time."""
        newest = max((modified for _, modified in self._list(key + "/")), default=None)
        if newest is not None:
            return newest
        head = self._head(key)
        return None if head is None else head["LastModified"].timestamp()

    def prepare(self) -> None:
        """Nothing: the bucket is made where the store is deployed (compose's minio-init)."""

    @_reaching
    def check(self) -> None:
        """One empty object written (reachable, the bucket there, writes allowed), tried once."""
        self.probe_client.put_object(Bucket=self.bucket, Key=self._key(PROBE_KEY), Body=b"")

    def _head(self, key: str) -> dict | None:
        """The object's metadata, or None where there is none."""
        try:
            return self.client.head_object(Bucket=self.bucket, Key=self._key(key))
        except ClientError as exc:
            if _status(exc) == 404:
                return None
            raise

    @_reaching
    def blob(self, key: str) -> Blob:
        try:
            answer = self.client.get_object(Bucket=self.bucket, Key=self._key(key))
        except ClientError as exc:
            raise _missing(exc, key) from exc
        return Blob(answer["ContentLength"], chunks=_closing_chunks(answer["Body"]))

    def _list(self, prefix: str) -> Iterator[tuple[str, float]]:
        """(full key, last modified) of every object under prefix."""
        for page in self._pages(prefix):
            for item in page.get("Contents", []):
                yield item["Key"], item["LastModified"].timestamp()

    def _pages(self, prefix: str, **options) -> Iterator[dict]:
        paginator = self.client.get_paginator("list_objects_v2")
        return paginator.paginate(Bucket=self.bucket, Prefix=self._key(prefix), **options,
                                  PaginationConfig={"PageSize": PAGE})

    # -- versions and scratch ---------------------------------------------------------------------

    @contextmanager
    def staging(self, project_id: int, prefix: str = "work-") -> Iterator[Path]:
        self.scratch_root.mkdir(parents=True, exist_ok=True)
        path = Path(tempfile.mkdtemp(prefix=f"{prefix}p{os.getpid()}-", dir=self.scratch_root))
        try:
            yield path
        finally:
            shutil.rmtree(path, ignore_errors=True)

    @_reaching
    def publish(self, project_id: int, staged: Path, reuse_from: Sequence[str] = ()) -> str:
        version = f"{project_prefix(project_id)}/versions/{uuid.uuid4().hex}"
        known = {entry["sha256"]: entry for source in reuse_from
                 for entry in self._manifest(source)["files"].values()}
        files = {}
        for path in sorted(p for p in staged.rglob("*") if p.is_file()):
            member, digest = path.relative_to(staged).as_posix(), _sha256(path)
            if digest in known:  # unchanged since a published version: share its object
                files[member] = known[digest]
                continue
            files[member] = {"key": f"{version}/files/{member}", "size": path.stat().st_size,
                             "sha256": digest}
            self.put(files[member]["key"], path)
        dirs = sorted(p.relative_to(staged).as_posix() for p in staged.rglob("*") if p.is_dir())
        self._write_manifest(version, {"files": files, "dirs": dirs})
        return version

    def _write_manifest(self, version: str, manifest: dict) -> None:
        """The last write of a publish: from here on the version exists."""
        self.put_bytes(f"{version}/{MANIFEST}", json.dumps(manifest, indent=1).encode())

    def _manifest(self, version: str) -> dict:
        try:
            answer = self.client.get_object(Bucket=self.bucket, Key=self._key(f"{version}/{MANIFEST}"))
        except ClientError as exc:
            if _status(exc) == 404:
                raise UnpublishedVersion(f"version {version} has no manifest: never published") from exc
            raise
        with answer["Body"] as body:
            return json.loads(body.read())

    @_reaching
    def checkout(self, version: str, scratch: Path, only: Sequence[str] | None = None) -> Path:
        manifest = self._manifest(version)
        target = Path(tempfile.mkdtemp(prefix="version-", dir=scratch))
        for folder in manifest["dirs"]:
            (target / folder).mkdir(parents=True, exist_ok=True)
        wanted = [(entry["key"], target / member) for member, entry in manifest["files"].items()
                  if only is None or member.startswith(tuple(only))]
        self._fetch_all(wanted)
        return target

    def _fetch_all(self, pairs: list[tuple[str, Path]]) -> None:
        with ThreadPoolExecutor(TRANSFERS) as pool:
            futures = [pool.submit(self.fetch, key, target) for key, target in pairs]
            try:
                for done in futures:
                    done.result()
            except BaseException:  # the first failure ends the fetch: the rest would meet it too
                for future in futures:
                    future.cancel()
                raise

    @_reaching
    def fetch_member(self, version: str, member: str, target: Path) -> bool:
        entry = self._manifest(version)["files"].get(member)
        if entry is None:
            return False
        self.fetch(entry["key"], target)
        return True

    @_reaching
    def copy_version(self, project_id: int, version: str) -> str:
        """A new manifest naming the same objects: restore writes one small object."""
        copy = f"{project_prefix(project_id)}/versions/{uuid.uuid4().hex}"
        self._write_manifest(copy, self._manifest(version))
        return copy

    @_reaching
    def images_for(self, project_id: int, names: Iterable[str], scratch: Path) -> Path:
        folder = scratch / "images"
        folder.mkdir(parents=True, exist_ok=True)
        self._fetch_all([(image_key(project_id, name), folder / name) for name in names
                         if not (folder / name).is_file()])
        return folder

    def image_location(self, project_id: int) -> str:
        return f"s3://{self.bucket}/{self._key(project_prefix(project_id))}/images"

    def clear_stale_scratch(self) -> int:
        """Scratch dirs whose process is gone (killed mid-job): named `...p{pid}-...`."""
        removed = 0
        for path in self.scratch_root.iterdir() if self.scratch_root.is_dir() else []:
            pid = _pid_in(path.name)
            if pid is not None and not _alive(pid):
                shutil.rmtree(path, ignore_errors=True)
                removed += 1
        return removed


def _status(exc: ClientError) -> int:
    return int(exc.response.get("ResponseMetadata", {}).get("HTTPStatusCode", 0))


def _reason(exc: Exception) -> str:
    """An S3 error code (SlowDown, AccessDenied, 500) or the kind of failure (no connection)."""
    if isinstance(exc, ClientError):
        return str(exc.response.get("Error", {}).get("Code", "") or _status(exc))
    cause = (exc.__cause__ or exc.__context__) if isinstance(exc, Boto3Error) else None  # a transfer's
    return _reason(cause) if isinstance(cause, UNAVAILABLE) else type(exc).__name__


def _missing(exc: ClientError, key: str) -> Exception:
    code = str(exc.response.get("Error", {}).get("Code", ""))
    return FileNotFoundError(f"no stored file {key}") if code in ("404", "NoSuchKey") else exc


def _closing_chunks(body) -> Iterator[bytes]:
    try:
        yield from body.iter_chunks(CHUNK)
    finally:
        body.close()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(CHUNK), b""):
            digest.update(block)
    return digest.hexdigest()


def _pid_in(name: str) -> int | None:
    for part in name.split("-"):
        if part.startswith("p") and part[1:].isdigit():
            return int(part[1:])
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
