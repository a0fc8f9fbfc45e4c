"""`serve --sample`: once per data dir, a user and a project holding the rendered sample, queued."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import tempfile
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

from sqlalchemy.orm import Session, sessionmaker

from guided_sfm import jobs
from guided_sfm.actions import images, projects
from guided_sfm.db import queries
from guided_sfm.db.models import Project, User
from guided_sfm.db.session import session_scope
from guided_sfm.settings import Settings
from guided_sfm.storage import Store, open_store

CREDENTIALS = "sample-credentials.json"
TRUTH = "sample-truth.json"  # the sample's ground truth, for evaluating corrections


def ensure(sessions: sessionmaker[Session], settings: Settings, submit: Callable[[int], None],
           hash_password: Callable[[str], str]) -> dict:
    """{"username", "password", "project_id"}: read from the data dir, or created now."""
    path = settings.data_dir / CREDENTIALS
    if path.is_file():
        return json.loads(path.read_text())
    from guided_sfm.sample import DEFAULT_LAYOUT, write_sample  # renders with numpy; only needed once

    store = open_store(settings)
    password = secrets.token_urlsafe(12)
    with tempfile.TemporaryDirectory(dir=settings.data_dir) as tmp, session_scope(sessions) as session:
        sample = write_sample(Path(tmp) / "sample", layout=DEFAULT_LAYOUT, seed=0)
        shutil.copy2(sample / "truth.json", settings.data_dir / TRUTH)
        user = _user(session, hash_password(password))
        project = projects.add(session, user.id, f"Sample ({DEFAULT_LAYOUT})",
                               "Rendered sample scene with repeated objects; its ground truth "
                               f"is {TRUTH} in the server's data directory.")
        _upload(session, store, project, sorted((sample / "images").iterdir()), settings)
        jobs.queue(session, submit, project, "reconstruct", user.id, {}, None)
        credentials = {"username": user.username, "password": password, "project_id": project.id}
    _write_private(path, json.dumps(credentials))
    return credentials


def _user(session: Session, password_hash: str) -> User:
    username = "demo"
    while queries.user_by_name(session, username) is not None:
        username = f"demo-{secrets.token_hex(2)}"
    user = User(username=username, password_hash=password_hash)
    session.add(user)
    session.flush()
    return user


def _upload(session: Session, store: Store, project: Project, files: list[Path],
            settings: Settings) -> None:
    with ExitStack() as stack:
        opened = [(p.name, stack.enter_context(open(p, "rb"))) for p in files]
        images.upload(session, store, project, opened, settings.max_upload_bytes)


def _write_private(path: Path, text: str) -> None:
    """Readable by its owner only (the file holds a password)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as handle:
        handle.write(text)
    os.chmod(path, 0o600)
