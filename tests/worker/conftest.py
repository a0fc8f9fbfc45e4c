"""Worker test fixtures: live services (API + real worker process) and the larger rendered sample."""

from pathlib import Path

import pytest

from tests.conftest import create_database
from tests.worker.live import Service


@pytest.fixture
def service_factory(tmp_path):
    made = []

    def make(broker_url: str, database_url: str | None = None, **overrides) -> Service:
        url, drop = (database_url, lambda: None) if database_url else create_database(tmp_path)
        service = Service(tmp_path, url, broker_url, **overrides)
        made.append((service, drop))
        return service

    yield make
    for service, drop in made:
        service.close()
        drop()


@pytest.fixture(scope="session")
def murals_images(tmp_path_factory) -> Path:
    from guided_sfm.sample import write_sample

    return write_sample(tmp_path_factory.mktemp("murals") / "sample", layout="murals", seed=0)
