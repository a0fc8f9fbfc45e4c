"""Builders for service tests: plain functions with keyword arguments."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import PIL.Image
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from guided_sfm.actions.images import make_thumbnail
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import Image, Project, Version
from guided_sfm.storage import ArtifactStore, link_tree

PASSWORD = "correct horse battery"


def signup(client: TestClient, username: str) -> dict[str, str]:
    """Create a user and return its Authorization header."""
    response = client.post("/api/v1/users", json={"username": username, "password": PASSWORD})
    assert response.status_code == 201, response.text
    token = client.post("/api/v1/auth/token", data={"username": username, "password": PASSWORD})
    return {"Authorization": f"Bearer {token.json()['access_token']}"}


def make_project(client: TestClient, headers: dict[str, str], name: str = "p") -> int:
    response = client.post("/api/v1/projects", json={"name": name}, headers=headers)
    assert response.status_code == 201, response.text
    return response.json()["id"]


def add_member(client: TestClient, owner: dict[str, str], pid: int, username: str, role: str) -> None:
    response = client.put(f"/api/v1/projects/{pid}/members/{username}", json={"role": role}, headers=owner)
    assert response.status_code == 200, response.text


def jpeg_bytes(width: int = 64, height: int = 48, color=(120, 30, 200), fmt: str = "JPEG") -> bytes:
    buffer = io.BytesIO()
    PIL.Image.new("RGB", (width, height), color).save(buffer, fmt)
    return buffer.getvalue()


def zip_bytes(entries: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in entries.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def workspace_zip(workspace: Path, images: Path) -> bytes:
    """A COLMAP workspace as the import route takes it: database.db, sparse/0/ (and any other
    sparse/<k>/), images/."""
    entries = {"database.db": (workspace / "database.db").read_bytes()}
    for path in sorted((workspace / "sparse").glob("*/*")):
        entries[path.relative_to(workspace).as_posix()] = path.read_bytes()
    for path in sorted(images.iterdir()):
        entries[f"images/{path.name}"] = path.read_bytes()
    return zip_bytes(entries)


def make_version(session: Session, store: ArtifactStore, project_id: int, workspace: Path,
                 images: Path, author_id: int | None = None) -> Version:
    """A head version from an existing workspace (linked, not reconstructed), with image rows."""
    project = session.get(Project, project_id)
    target = store.images_dir(project_id)
    link_tree(images, target)
    rows = []
    for seq, path in enumerate(sorted(images.iterdir())):
        with PIL.Image.open(path) as img:
            rows.append(Image(project_id=project_id, name=path.name, width=img.width, height=img.height,
                              seq=seq))
    session.add_all(rows)
    session.flush()
    for row in rows:
        make_thumbnail(target / row.name, store.thumbnail(project_id, row.id))
    with store.staging(project_id) as staging:
        link_tree(workspace, staging / "ws")
        Workspace(staging / "ws").write_meta({"image_dir": str(target)})
        relative = store.publish(project_id, staging / "ws")
    version = Version(project_id=project_id, parent_id=project.head_version_id, kind="reconstruct",
                      author_id=author_id, message="made by a test", stats=Workspace(workspace).stats(),
                      path=relative)
    session.add(version)
    session.flush()
    project.head_version_id = version.id
    session.commit()
    return version
