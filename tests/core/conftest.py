"""Session fixtures: the tiny rendered sample, reconstructed once with real pycolmap."""

import shutil
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)
import pycolmap
import pytest

from guided_sfm.core.sfm import RunContext, SfmOptions, set_colmap_verbosity
from guided_sfm.core.workspace import Workspace
from guided_sfm.sample import write_sample

set_colmap_verbosity(False)
TINY_OPTIONS = SfmOptions(max_num_features=1024, num_threads=2)


@pytest.fixture(scope="session")
def tiny_sample(tmp_path_factory) -> Path:
    return write_sample(tmp_path_factory.mktemp("tiny") / "sample", "tiny", seed=0)


@pytest.fixture(scope="session")
def tiny_workspace_ro(tiny_sample, tmp_path_factory) -> Path:
    """A reconstructed workspace that tests must not change (copy it with `tiny_workspace`)."""
    pycolmap.set_random_seed(0)
    ws = tmp_path_factory.mktemp("tiny-ws") / "ws"
    Workspace(ws).reconstruct(tiny_sample / "images", RunContext(TINY_OPTIONS))
    return ws


@pytest.fixture
def tiny_workspace(tiny_workspace_ro, tmp_path) -> Path:
    """A private copy of the reconstructed tiny workspace."""
    return Path(shutil.copytree(tiny_workspace_ro, tmp_path / "ws"))
