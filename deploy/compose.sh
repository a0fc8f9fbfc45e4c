#!/usr/bin/env bash
# make compose-up / make compose-down: build the image and start the compose stack detached (up
# returns once the API answers), or stop it. Docker compose where `docker info` works, else podman
# with this machine's override (deploy/podman/stack.sh). No variables needed: a signing key is
# generated once into .env (ignored by git; docker compose reads it from the project directory).
set -euo pipefail
cd "$(dirname "$0")/.."
PORT=${GUIDED_SFM_PORT:-8000}

secret_key() {
  [ -n "${GUIDED_SFM_SECRET_KEY:-}" ] && return
  if ! grep -q '^GUIDED_SFM_SECRET_KEY=' .env 2>/dev/null; then
    umask 077
    echo "GUIDED_SFM_SECRET_KEY=$(od -An -N32 -tx1 /dev/urandom | tr -d ' \n')" >>.env
    echo "generated GUIDED_SFM_SECRET_KEY into .env" >&2
  fi
  set -a && . ./.env && set +a
}

wait_for_api() {
  local deadline=$((SECONDS + 300))
  until python3 -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:$PORT/api/v1/health', timeout=3)" 2>/dev/null; do
    [ $SECONDS -lt $deadline ] || { echo "the API did not answer on port $PORT in 300 s" >&2; exit 1; }
    sleep 2
  done
  echo "up: http://127.0.0.1:$PORT/" >&2
}

case "${1:-}" in
  up)
    secret_key
    if docker info >/dev/null 2>&1; then
      docker compose up -d --build && wait_for_api
    else
      deploy/podman/stack.sh up
    fi ;;
  down)
    shift
    [ -f .env ] && set -a && . ./.env && set +a
    export GUIDED_SFM_SECRET_KEY=${GUIDED_SFM_SECRET_KEY:-not-needed-to-stop-the-stack}  # the file must parse
    if docker info >/dev/null 2>&1; then
      docker compose down $([ "${1:-}" = --purge ] && echo --volumes)
    else
      deploy/podman/stack.sh down "$@"
    fi ;;
  *) echo "usage: $0 up | down" >&2; exit 2 ;;
esac
