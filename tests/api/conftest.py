"""API fixtures: a project whose head is the tiny sample's reconstruction (linked, not recomputed)."""

from dataclasses import dataclass

import pytest

from guided_sfm.storage import ArtifactStore
from tests.factories import make_project, make_version, signup


@dataclass
class Scene:
    pid: int
    vid: int
    owner: dict[str, str]
    image_ids: dict[str, int]  # name -> REST id


@pytest.fixture
def store(settings) -> ArtifactStore:
    return ArtifactStore(settings.artifacts_dir)


@pytest.fixture
def reconstructed(client, session, store, tiny_reconstruction, tiny_images) -> Scene:
    owner = signup(client, "owner")
    pid = make_project(client, owner, "tiny")
    version = make_version(session, store, pid, tiny_reconstruction, tiny_images / "images")
    images = client.get(f"/api/v1/projects/{pid}/images", headers=owner).json()
    return Scene(pid, version.id, owner, {i["name"]: i["id"] for i in images})
