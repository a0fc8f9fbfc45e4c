"""docker-compose.yml, the Dockerfile and this machine's override against the settings and the CLI.

The fast check: nothing runs here. The stack itself runs with `make compose-up` and
deploy/compose_loop.py (minutes; README, "Deployment").
"""

import importlib.util
import re
from pathlib import Path

import pytest
import yaml

from guided_sfm.cli import build_parser
from guided_sfm.settings import PREFIX, Settings

ROOT = Path(__file__).resolve().parents[1]


class Recording(dict):
    def get(self, key, default=None):
        self.setdefault("_read", set()).add(key)
        return super().get(key, default)


def settings_variables() -> set[str]:
    env = Recording()
    Settings.from_env(env)
    return env["_read"]


def substitute(value: str) -> str:
    """Compose's ${VAR:-default} / ${VAR:?message} with nothing set: defaults, or a sample value."""
    value = re.sub(r"\$\{[A-Z0-9_]+:-([^}]*)\}", r"\1", str(value))
    return re.sub(r"\$\{[A-Z0-9_]+:\?[^}]*\}", "x" * 32, value)


@pytest.fixture(scope="module")
def compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_services_and_volumes(compose):
    services = compose["services"]
    assert set(services) == {"postgres", "redis", "minio", "minio-init", "api", "worker"}
    assert set(compose["volumes"]) == {"pgdata", "redisdata", "miniodata", "artifacts"}
    long_running = {name for name, service in services.items() if service["restart"] == "unless-stopped"}
    assert long_running == set(services) - {"minio-init"}
    assert all("healthcheck" in services[name] for name in long_running)
    assert services["worker"]["cpus"] == 2
    assert services["api"]["depends_on"]["minio-init"] == {"condition": "service_completed_successfully"}
    assert services["minio-init"]["depends_on"]["minio"] == {"condition": "service_healthy"}


def test_s3_store_is_prepared(compose):
    """The bucket minio-init makes is the one GUIDED_SFM_ARTIFACTS_URL names, with MinIO's keys."""
    s3 = {k: substitute(v) for k, v in compose["x-s3-env"].items()}
    minio = {k: substitute(v) for k, v in compose["services"]["minio"]["environment"].items()}
    assert s3["GUIDED_SFM_ARTIFACTS_URL"] == "s3://guided-sfm/artifacts"
    assert s3["GUIDED_SFM_S3_ENDPOINT_URL"] == "http://minio:9000"
    assert (s3["AWS_ACCESS_KEY_ID"], s3["AWS_SECRET_ACCESS_KEY"]) == (minio["MINIO_ROOT_USER"],
                                                                      minio["MINIO_ROOT_PASSWORD"])
    init = compose["services"]["minio-init"]
    assert init["environment"] == compose["x-s3-env"]
    assert "mc mb --ignore-existing store/guided-sfm" in substitute(init["command"][0])


def test_commands_are_cli_subcommands(compose):
    parser = build_parser()
    for name, expected in (("api", "api"), ("worker", "worker")):
        command = compose["services"][name]["command"]
        assert command[0] == "guided-sfm" and command[1] == expected
        args = parser.parse_args(command[1:])
        assert args.func.__name__ == f"cmd_{expected}"
    assert parser.parse_args(compose["services"]["api"]["command"][1:]).host == "0.0.0.0"


def test_environment_matches_settings(compose):
    known = settings_variables()
    for name in ("api", "worker"):
        env = {k: substitute(v) for k, v in compose["services"][name]["environment"].items()}
        assert set(env) <= known, set(env) - known
        assert {PREFIX + k for k in ("DATABASE_URL", "BROKER_URL", "DATA_DIR", "SECRET_KEY")} <= set(env)
        settings = Settings.from_env(env)
        assert settings.database_url.startswith("postgresql+psycopg://")
        assert "@postgres:5432/" in settings.database_url
        assert settings.broker_url == "redis://redis:6379/0" and settings.threads == 2
        assert ("artifacts:" + str(settings.data_dir)) in compose["services"][name]["volumes"]
    secret = compose["services"]["api"]["environment"][PREFIX + "SECRET_KEY"]
    assert ":?" in secret  # no default signing key in a deployment


def test_database_and_broker_volumes(compose):
    assert "pgdata:/var/lib/postgresql/data" in compose["services"]["postgres"]["volumes"]
    assert "redisdata:/data" in compose["services"]["redis"]["volumes"]
    user = compose["services"]["postgres"]["environment"]
    url = substitute(compose["services"]["api"]["environment"][PREFIX + "DATABASE_URL"])
    assert url.endswith(f"@postgres:5432/{user['POSTGRES_DB']}") and f"//{user['POSTGRES_USER']}:" in url


def test_dockerfile_ships_what_the_commands_need():
    dockerfile = (ROOT / "Dockerfile").read_text()
    ignored = (ROOT / ".dockerignore").read_text().split()
    for folder in ("services", "worker", "migrations", "frontend"):
        assert f"COPY {folder} ./{folder}" in dockerfile and f"!{folder}" in ignored
    assert "pip install -e ." in dockerfile and "GUIDED_SFM_DATA_DIR=/data" in dockerfile
    assert "ARG BASE_IMAGE=python:3.11-slim\nFROM ${BASE_IMAGE}" in dockerfile
    assert re.search(r"^USER app$", dockerfile, re.M) and "useradd --create-home --uid 1000 app" in dockerfile
    assert re.search(r"^HEALTHCHECK .*\n.*/api/v1/health", dockerfile, re.M)
    assert not re.search(r"^ARG PIP_\w+=", dockerfile, re.M)  # the index, unless a build says otherwise


def local_override():
    path = ROOT / "deploy" / "podman" / "local_compose.py"
    spec = importlib.util.spec_from_file_location("local_compose", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_local_override_keeps_the_file_but_what_this_machine_lacks(compose):
    database, broker = "postgresql+psycopg://postgres@127.0.0.1:5432/stack", "redis://127.0.0.1:6379/11"
    local = local_override().local(compose, database, broker, "9100", "8100")
    services = local["services"]
    assert set(services) == set(compose["services"]) - {"postgres", "redis"}
    assert set(local["volumes"]) == {"miniodata", "artifacts"}
    for name, service in services.items():
        assert service["network_mode"] == "host" and "ports" not in service
        assert not {"postgres", "redis"} & set(service.get("depends_on", {}))
        assert service.get("healthcheck", {"test": ["CMD-SHELL"]})["test"][0] == "CMD-SHELL"
        assert service["restart"] == compose["services"][name]["restart"]
    for name in ("api", "worker"):
        env, original = services[name]["environment"], compose["services"][name]
        assert (env["GUIDED_SFM_DATABASE_URL"], env["GUIDED_SFM_BROKER_URL"]) == (database, broker)
        assert services[name]["volumes"] == original["volumes"]
        assert services[name]["image"] == "localhost/guided-sfm:latest"
        assert services[name]["command"][:-1] == original["command"][:-1]
    assert services["api"]["command"][-1] == "8100"
    assert "127.0.0.1:8100/api/v1/health" in services["api"]["healthcheck"]["test"][1]
    assert services["worker"]["cpus"] == 2 and services["worker"]["command"] == ["guided-sfm", "worker"]
    assert services["minio-init"]["environment"]["GUIDED_SFM_S3_ENDPOINT_URL"] == "http://127.0.0.1:9100"
    assert "9100" in services["minio"]["command"]
    assert compose["services"]["api"]["environment"]["GUIDED_SFM_BROKER_URL"] == "redis://redis:6379/0"
