"""The compose file for this machine, derived from docker-compose.yml (printed to stdout).

What differs, and why (README, "Deployment"):
- host networking: podman's bridge cannot reach the machine's own Postgres and Redis, which
  listen on loopback only; the api listens on GUIDED_SFM_PORT itself (no port mapping);
- postgres and redis: the machine's own (their images are in no registry reachable here, and
  their ports are taken), with a database and a Redis database number of the stack's own;
- minio and minio-init: moto's S3 server from PyPI (the bucket in its memory: no volume) and a
  boto3 script, in an image built here;
- images built here on a debootstrapped Debian (see stack.sh), never pulled.
Usage: local_compose.py docker-compose.yml DATABASE_URL BROKER_URL S3_PORT API_PORT
       local_compose.py --env SERVICE LOCAL_COMPOSE_FILE   (its environment, filled, as KEY=VALUE lines)
"""

import json
import os
import re
import shlex
import sys
from collections.abc import Mapping

import yaml

MACHINE_SERVICES = ("postgres", "redis")
S3_IMAGE = "localhost/guided-sfm-s3-local:latest"
APP_IMAGE = "localhost/guided-sfm:latest"
VARIABLE = re.compile(r"\$\{(\w+)(:-|:\?)([^}]*)\}")  # compose's ${VAR:-default} and ${VAR:?message}


def http_check(url: str) -> list[str]:
    return ["CMD", "python", "-c", f'import urllib.request; urllib.request.urlopen("{url}", timeout=3)']


def local(compose: dict, database_url: str, broker_url: str, s3_port: str, api_port: str) -> dict:
    compose = json.loads(json.dumps(compose))  # no shared mappings (YAML anchors) left
    services = compose["services"]
    for name in MACHINE_SERVICES:
        del services[name]
    s3_url = f"http://127.0.0.1:{s3_port}"
    for name, service in services.items():
        on_host_network(service, f"{compose['name']}-{name}")
        env = service.get("environment", {})
        if "GUIDED_SFM_S3_ENDPOINT_URL" in env:
            env["GUIDED_SFM_S3_ENDPOINT_URL"] = s3_url
        if "GUIDED_SFM_DATABASE_URL" in env:
            env.update(GUIDED_SFM_DATABASE_URL=database_url, GUIDED_SFM_BROKER_URL=broker_url)
    s3_stand_in(services, s3_port, s3_url)
    api = services["api"]
    api.pop("build", None)
    api["command"] = [*api["command"][:-1], api_port]
    api["healthcheck"]["test"] = http_check(f"http://127.0.0.1:{api_port}/api/v1/health")
    services["worker"]["image"] = api["image"] = APP_IMAGE
    for service in services.values():
        if "healthcheck" in service:  # podman-compose 1.0.3 mangles the exec form
            service["healthcheck"]["test"] = ["CMD-SHELL", shlex.join(service["healthcheck"]["test"][1:])]
    used = {volume.split(":")[0] for service in services.values() for volume in service.get("volumes", [])}
    compose["volumes"] = {k: v for k, v in compose["volumes"].items() if k in used} or None
    return {key: value for key, value in compose.items() if not key.startswith("x-") and value is not None}


def on_host_network(service: dict, hostname: str) -> None:
    service["network_mode"] = "host"
    service["hostname"] = hostname  # else the machine's own: the worker's container is told apart
    service.pop("ports", None)
    deps = service.get("depends_on", {})
    for name in MACHINE_SERVICES:
        deps.pop(name, None)
    if not deps:
        service.pop("depends_on", None)


def s3_stand_in(services: dict, s3_port: str, s3_url: str) -> None:
    minio, init = services["minio"], services["minio-init"]
    minio.update(image=S3_IMAGE, environment={},
                 command=["moto_server", "--host", "127.0.0.1", "--port", s3_port],
                 healthcheck={**minio["healthcheck"], "test": http_check(s3_url)})
    minio.pop("volumes", None)  # moto keeps the bucket in memory
    init.update(image=S3_IMAGE, command=["python", "/usr/local/bin/create_bucket.py"])
    init.pop("entrypoint", None)


def resolved_env(service: dict, environ: Mapping[str, str]) -> list[str]:
    """A service's environment as KEY=VALUE, with compose's ${VAR:-default} and ${VAR:?message}
    filled from environ (for a container started without compose: stack.sh's extra workers)."""

    def fill(match: re.Match) -> str:
        name, kind, rest = match.groups()
        if environ.get(name):
            return environ[name]
        if kind == ":?":
            raise SystemExit(f"{name} is not set: {rest}")
        return rest

    env = service.get("environment", {})
    return [f"{key}={VARIABLE.sub(fill, str(value))}" for key, value in env.items()]


def main() -> None:
    if sys.argv[1] == "--env":  # --env SERVICE LOCAL_COMPOSE_FILE
        with open(sys.argv[3]) as handle:
            service = yaml.safe_load(handle)["services"][sys.argv[2]]
        print("\n".join(resolved_env(service, os.environ)))
        return
    path, database_url, broker_url, s3_port, api_port = sys.argv[1:]
    with open(path) as handle:
        compose = yaml.safe_load(handle)
    yaml.safe_dump(local(compose, database_url, broker_url, s3_port, api_port), sys.stdout, sort_keys=False)


if __name__ == "__main__":
    main()
