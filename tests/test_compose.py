"""docker-compose.yml against the settings and the CLI (no Docker engine runs here)."""

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
    value = re.sub(r"\$\{[A-Z_]+:-([^}]*)\}", r"\1", str(value))
    return re.sub(r"\$\{[A-Z_]+:\?[^}]*\}", "x" * 32, value)


@pytest.fixture(scope="module")
def compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_services_and_volumes(compose):
    assert set(compose["services"]) == {"postgres", "redis", "api", "worker"}
    assert set(compose["volumes"]) == {"pgdata", "redisdata", "artifacts"}
    assert all("healthcheck" in service for service in compose["services"].values())
    assert compose["services"]["worker"]["cpus"] == 2


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
    for folder in ("services", "worker", "migrations", "frontend"):
        assert f"COPY {folder} ./{folder}" in dockerfile
    assert "pip install -e ." in dockerfile and "GUIDED_SFM_DATA_DIR=/data" in dockerfile
