"""Service fixtures: settings on a tmp dir, a DB chosen by env and migrated by Alembic, savepoint
isolation per in-process test, committed databases for tests with real worker processes."""

from __future__ import annotations

import os
import shutil
import uuid
import warnings
from collections.abc import Iterator
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)
import pycolmap
import pytest
from sqlalchemy import make_url, text
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.api.app import create_app
from guided_sfm.core.sfm import RunContext, SfmOptions, set_colmap_verbosity
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.migrate import upgrade
from guided_sfm.db.session import make_engine
from guided_sfm.settings import Settings

with warnings.catch_warnings():
    # Starlette 1.x warns at import that it prefers httpx2 over httpx; the client works the same.
    warnings.filterwarnings("ignore", message=".*httpx2.*")
    from fastapi.testclient import TestClient

TEST_DATABASE_ENV = "GUIDED_SFM_TEST_DATABASE_URL"
SECRET = "test-secret-key-not-for-production"
TINY_OPTIONS = SfmOptions(max_num_features=1024, num_threads=2)


def create_database(tmp_dir: Path) -> tuple[str, callable]:
    """A fresh, migrated database of the kind the env asks for; returns (url, drop)."""
    base = os.environ.get(TEST_DATABASE_ENV, "")
    if not base or base.startswith("sqlite"):
        url = f"sqlite:///{tmp_dir / f'test-{uuid.uuid4().hex[:8]}.db'}"
        upgrade(url)
        return url, lambda: None
    # a shared server: GUIDED_SFM_TEST_DATABASE_PREFIX keeps each user's databases apart
    name = f"{os.environ.get('GUIDED_SFM_TEST_DATABASE_PREFIX', 'gsfm_test_')}{uuid.uuid4().hex[:12]}"
    admin = make_engine(make_url(base).set(database="postgres").render_as_string(False),
                        isolation_level="AUTOCOMMIT")
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    url = make_url(base).set(database=name).render_as_string(False)
    upgrade(url)

    def drop() -> None:
        with admin.connect() as conn:
            conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()

    return url, drop


@pytest.fixture(scope="session")
def database_url(tmp_path_factory) -> Iterator[str]:
    url, drop = create_database(tmp_path_factory.mktemp("db"))
    yield url
    drop()


@pytest.fixture(scope="session")
def engine(database_url):
    engine = make_engine(database_url)
    yield engine
    engine.dispose()


@pytest.fixture
def sessions(engine) -> Iterator[sessionmaker[Session]]:
    """Sessions on one connection whose outer transaction is rolled back after the test; their
    commits only release savepoints."""
    connection = engine.connect()
    outer = connection.begin()
    yield sessionmaker(bind=connection, join_transaction_mode="create_savepoint", expire_on_commit=False)
    outer.rollback()
    connection.close()


@pytest.fixture
def session(sessions) -> Iterator[Session]:
    with sessions() as session:
        yield session


def make_settings(data_dir: Path, database_url: str, **overrides) -> Settings:
    values = {"data_dir": data_dir, "database_url": database_url, "secret_key": SECRET,
              "heartbeat_seconds": 3600.0, **overrides}  # no heartbeat thread on a shared connection
    return Settings.from_env({}, **values)


@pytest.fixture
def settings(tmp_path, database_url) -> Settings:
    return make_settings(tmp_path / "data", database_url)


@pytest.fixture
def submitted() -> list[int]:
    """Job ids the API enqueued (in-process tests run them with runner.run_job)."""
    return []


@pytest.fixture
def client(settings, sessions, submitted) -> Iterator[TestClient]:
    with TestClient(create_app(settings, submitted.append, sessions=sessions)) as client:
        yield client


@pytest.fixture
def committed_database(tmp_path) -> Iterator[str]:
    """A database of its own, for tests whose worker processes must see committed rows."""
    url, drop = create_database(tmp_path)
    yield url
    drop()


@pytest.fixture(scope="session")
def tiny_images(tmp_path_factory) -> Path:
    from guided_sfm.sample import write_sample

    return write_sample(tmp_path_factory.mktemp("tiny") / "sample", layout="tiny", seed=0)


@pytest.fixture(scope="session")
def tiny_reconstruction(tiny_images, tmp_path_factory) -> Path:
    """The tiny sample reconstructed once; tests link it into their own versions, never change it."""
    set_colmap_verbosity(False)
    pycolmap.set_random_seed(0)
    workspace = tmp_path_factory.mktemp("tiny-ws") / "ws"
    Workspace(workspace).reconstruct(tiny_images / "images", RunContext(TINY_OPTIONS))
    return workspace


def copy_images(source: Path, target: Path) -> Path:
    shutil.copytree(source, target)
    return target


@pytest.fixture(scope="session")
def moto_server(tmp_path_factory):
    """A real S3 endpoint (moto's server mode in a subprocess on a free port) for the whole run."""
    from tests.s3server import MotoServer

    server = MotoServer(tmp_path_factory.mktemp("moto") / "moto.log")
    yield server
    server.stop()
