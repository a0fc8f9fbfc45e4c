"""Service settings: one frozen dataclass read from an environ mapping; nothing is built at import."""

from __future__ import annotations

import os
import secrets
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TypeVar
from urllib.parse import urlsplit

PREFIX = "GUIDED_SFM_"
DEFAULT_DATA_DIR = "data"  # relative to the working directory, like `serve --data-dir data`
DATABASE_SCHEMES = ("sqlite", "postgresql")
BROKER_SCHEMES = ("redis", "rediss", "filesystem", "memory")
TRUE, FALSE = ("1", "true", "yes", "on"), ("0", "false", "no", "off")
T = TypeVar("T", int, float)


class SettingsError(ValueError):
    """An environment variable holds a value the service cannot use."""


@dataclass(frozen=True)
class Settings:
    data_dir: Path
    database_url: str
    broker_url: str
    threads: int = 2
    open_signup: bool = True
    max_upload_mb: int = 1024
    max_image_mpx: int = 100  # larger images are refused from their header, before any decode
    secret_key: str | None = None
    token_minutes: int = 7 * 24 * 60
    sweep_seconds: float = 30.0  # sweeper period
    heartbeat_seconds: float = 5.0  # a running job touches its row this often
    stale_seconds: float = 60.0  # a running job silent this long lost its worker
    requeue_seconds: float = 60.0  # a queued job untouched this long lost its message
    max_attempts: int = 2  # a job whose worker died runs again until it has started this often
    login_attempts_per_user: int = 10  # failed logins per username per window, then 429
    login_attempts_per_address: int = 30  # logins and sign-ups per client address per window
    login_window_seconds: float = 300.0
    trusted_proxies: str = ""  # comma-separated peers whose X-Forwarded-For is believed
    webhook_allow_private: bool = False  # webhooks to loopback/private addresses (tests, intranets)
    webhook_retry_seconds: float = 10.0  # first retry after a failed delivery; doubles each time
    webhook_attempts: int = 6  # deliveries given up after this many tries
    webhook_timeout_seconds: float = 5.0  # per delivery request
    orphan_grace_seconds: float = 600.0  # files without rows this old are removed (reconcile)
    job_base_seconds: float = 3600.0  # a job's time limit: this much ...
    job_seconds_per_image: float = 60.0  # ... plus this per image of its project
    store_wait_seconds: float = 300.0  # a job waits this long for the artifact store to answer again
    artifacts_url: str = ""  # s3://BUCKET/PREFIX: the S3 store; empty: the data dir (design.md v1.1)
    s3_endpoint_url: str = ""  # an S3-compatible server's URL (MinIO, moto); empty: AWS

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None, **overrides: object) -> Settings:
        """Settings from GUIDED_SFM_* variables; keyword overrides win (e.g. data_dir from a flag)."""
        env = os.environ if environ is None else environ
        data_dir = Path(overrides.pop("data_dir", None) or env.get(PREFIX + "DATA_DIR") or DEFAULT_DATA_DIR)
        data_dir = data_dir.expanduser().absolute()
        values: dict[str, object] = {
            "data_dir": data_dir,
            "database_url": env.get(PREFIX + "DATABASE_URL") or f"sqlite:///{data_dir / 'guided_sfm.db'}",
            "broker_url": env.get(PREFIX + "BROKER_URL") or "filesystem://",
            "open_signup": _bool(env, "OPEN_SIGNUP", True),
            "webhook_allow_private": _bool(env, "WEBHOOK_ALLOW_PRIVATE", False),
            "secret_key": env.get(PREFIX + "SECRET_KEY") or None,
            "trusted_proxies": env.get(PREFIX + "TRUSTED_PROXIES") or "",
            "artifacts_url": env.get(PREFIX + "ARTIFACTS_URL") or "",
            "s3_endpoint_url": env.get(PREFIX + "S3_ENDPOINT_URL") or "",
            **{name: _number(env, name.upper(), default) for name, default in _numeric_defaults()},
        }
        values.update(overrides)
        settings = cls(**values)  # type: ignore[arg-type]
        settings.validate()
        return settings

    def validate(self) -> None:
        scheme = urlsplit(self.database_url).scheme.split("+")[0]
        if scheme not in DATABASE_SCHEMES:
            raise SettingsError(f"{PREFIX}DATABASE_URL must be sqlite or postgresql, got {scheme!r}")
        if urlsplit(self.broker_url).scheme not in BROKER_SCHEMES:
            raise SettingsError(
                f"{PREFIX}BROKER_URL must be redis:// or filesystem://, got {self.broker_url!r}")
        if min(self.threads, self.max_upload_mb, self.max_image_mpx) < 1:
            raise SettingsError(
                f"{PREFIX}THREADS, {PREFIX}MAX_UPLOAD_MB and {PREFIX}MAX_IMAGE_MPX must be >= 1")
        if self.artifacts_url:
            _check_artifacts_url(self.artifacts_url)
        if self.s3_endpoint_url and urlsplit(self.s3_endpoint_url).scheme not in ("http", "https"):
            raise SettingsError(f"{PREFIX}S3_ENDPOINT_URL must be http(s)://HOST[:PORT], "
                                f"got {self.s3_endpoint_url!r}")
        if self.secret_key is not None and len(self.secret_key) < 16:
            raise SettingsError(f"{PREFIX}SECRET_KEY must be at least 16 characters")

    @property
    def is_sqlite(self) -> bool:
        return self.database_url.startswith("sqlite")

    @property
    def artifacts_dir(self) -> Path:
        return self.data_dir / "artifacts"

    @property
    def broker_dir(self) -> Path:
        """Folder of the filesystem broker: the URL's path if it has one, else under the data dir."""
        path = urlsplit(self.broker_url).path
        return Path(path) if path not in ("", "/") else self.data_dir / "broker"

    @property
    def trusted_proxy_list(self) -> list[str]:
        return [part.strip() for part in self.trusted_proxies.split(",") if part.strip()]

    @property
    def max_upload_bytes(self) -> int:
        return self.max_upload_mb * 1024 * 1024

    def job_seconds(self, num_images: int) -> float:
        """A job's time limit in a project of this many images: a base plus a share per image."""
        return self.job_base_seconds + self.job_seconds_per_image * num_images

    def with_secret(self) -> Settings:
        """These settings with a signing key: the configured one, else one kept in the data dir."""
        if self.secret_key:
            return self
        path = self.data_dir / "secret_key"
        if not path.is_file():
            self.data_dir.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "w") as handle:
                handle.write(secrets.token_urlsafe(48))
        return replace(self, secret_key=path.read_text().strip())


def _check_artifacts_url(url: str) -> None:
    parts = urlsplit(url)
    if parts.scheme != "s3" or not parts.netloc:
        raise SettingsError(f"{PREFIX}ARTIFACTS_URL must be s3://BUCKET/PREFIX (or unset for the data dir), "
                            f"got {url!r}")


def _numeric_defaults() -> list[tuple[str, int | float]]:
    """The numeric fields and their defaults; each is read from GUIDED_SFM_<FIELD NAME>."""
    return [(f.name, f.default) for f in fields(Settings) if type(f.default) in (int, float)]


def _number(env: Mapping[str, str], name: str, default: T) -> T:
    """A numeric setting parsed as its default's type; the default when unset or empty."""
    raw, kind = env.get(PREFIX + name), type(default)
    try:
        return default if raw in (None, "") else kind(raw)
    except ValueError as exc:
        what = "an integer" if kind is int else "a number"
        raise SettingsError(f"{PREFIX}{name} must be {what}, got {raw!r}") from exc


def _bool(env: Mapping[str, str], name: str, default: bool) -> bool:
    raw = (env.get(PREFIX + name) or "").strip().lower()
    if not raw:
        return default
    if raw in TRUE or raw in FALSE:
        return raw in TRUE
    raise SettingsError(f"{PREFIX}{name} must be true or false, got {raw!r}")
