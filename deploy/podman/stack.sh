#!/usr/bin/env bash
# The compose stack where no Docker engine answers: podman + podman-compose (Debian's), on the
# host network, with the machine's own Postgres and Redis and moto's S3 server in place of MinIO.
# No container registry is reachable, so the images are built here: a Debian bookworm base made
# with debootstrap, the Python packages from a wheelhouse made beforehand (`pip wheel` in a
# throwaway container of the base; the builds run with --network none). Both are cached outside
# the repository, so a second `up` takes under a minute.
#   deploy/podman/stack.sh up | down [--purge]     (make compose-up / make compose-down)
#   deploy/podman/stack.sh worker NAME             one more worker container, as on another host
# --purge also removes the stack's volumes, its database and its Redis database number.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
CACHE=${GUIDED_SFM_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/guided-sfm}/podman
PROJECT=guided-sfm
PORT=${GUIDED_SFM_PORT:-8000}
S3_PORT=${GUIDED_SFM_S3_PORT:-9000}
# This machine's share of its Postgres and Redis (the environment may override it).
set -a && . "$HERE/local.env" && set +a
DATABASE=$GUIDED_SFM_LOCAL_DATABASE
BROKER_URL=$GUIDED_SFM_LOCAL_BROKER_URL
PG_URL=postgresql+psycopg://postgres@127.0.0.1:5432/$DATABASE
BASE=localhost/guided-sfm-base:bookworm
APP=localhost/guided-sfm:latest
S3=localhost/guided-sfm-s3-local:latest
MOTO='moto[server]>=5,<6'
HOST_CA=/etc/ssl/certs/ca-certificates.crt
export CONTAINERS_CONF=$HERE/containers.conf
mkdir -p "$CACHE"
LOG=$CACHE/stack.log

say() { printf '[compose %s] %s\n' "$(date +%T)" "$*" >&2; }
die() { say "error: $*"; exit 1; }

need_packages() {
  local missing=()
  for tool in podman runc podman-compose debootstrap; do
    command -v "$tool" >/dev/null || missing+=("$tool")
  done
  [ ${#missing[@]} -eq 0 ] && return
  say "installing ${missing[*]} (apt-get)"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq podman runc podman-compose debootstrap >>"$LOG"
}

base_image() {  # Debian bookworm (Python 3.11) with what the images need; minutes, once
  podman image exists "$BASE" && return
  local tarball=$CACHE/base-bookworm.tar rootfs=$CACHE/rootfs
  if [ ! -f "$tarball" ]; then
    say "debootstrap of Debian bookworm into $rootfs (once; 2 to 13 minutes measured here)"
    rm -rf "$rootfs"
    debootstrap --variant=minbase --include=python3,python3-venv,libgomp1 bookworm "$rootfs" >>"$LOG"
    rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
    tar -C "$rootfs" --exclude='./proc/*' --exclude='./sys/*' --exclude='./dev/*' -cf "$tarball.tmp" .
    mv "$tarball.tmp" "$tarball" && rm -rf "$rootfs"
  fi
  podman import --change 'CMD ["/bin/bash"]' "$tarball" "$BASE" >>"$LOG"
}

wheelhouse() {  # every wheel the two images install; again only when the requirements change
  local wheels=$CACHE/wheels requirements stamp
  requirements=$(python3 -c "import tomllib; print('\n'.join(tomllib.load(open('$ROOT/pyproject.toml', 'rb'))['project']['dependencies']))")
  requirements+=$'\nsetuptools>=77\n'"$MOTO"
  stamp=$(printf '%s' "$requirements" | sha256sum | cut -d' ' -f1)
  [ "$(cat "$wheels/.stamp" 2>/dev/null)" = "$stamp" ] && return
  # pip of the base's own Python judges the markers: bookworm's 3.11.2 needs wheels that the
  # host's Python may not (redis wants async-timeout below 3.11.3). A throwaway container, not a
  # build; it trusts the host's certificate authorities (a TLS-inspecting proxy's, where there is one).
  say "building the wheelhouse in $wheels (pip wheel in a container of the base image)"
  rm -rf "$wheels" && mkdir -p "$wheels"
  printf '%s\n' "$requirements" >"$wheels/requirements.txt"
  local ca=(); [ -f "$HOST_CA" ] && ca=(-v "$HOST_CA:/host-ca.crt:ro" -e PIP_CERT=/host-ca.crt)
  podman run --rm --network host -v "$wheels:/wheels" "${ca[@]}" "$BASE" sh -c 'python3 -m venv /tmp/pip &&
    /tmp/pip/bin/pip wheel --quiet --disable-pip-version-check -w /wheels -r /wheels/requirements.txt' >>"$LOG"
  echo "$stamp" >"$wheels/.stamp"
}

build_images() {  # the project's Dockerfile as a Docker host builds it, but from here's base and wheels
  say "building $APP and $S3 (no network inside the builds)"
  local args=(--format docker --network none -v "$CACHE/wheels:/wheels:ro" --build-arg "BASE_IMAGE=$BASE"
              --build-arg PIP_NO_INDEX=1 --build-arg PIP_FIND_LINKS=/wheels)
  podman build "${args[@]}" -t "$APP" "$ROOT" >>"$LOG"
  podman build "${args[@]}" --build-arg "MOTO_SPEC=$MOTO" -t "$S3" -f "$HERE/s3.Containerfile" "$HERE" >>"$LOG"
  podman image prune -f >>"$LOG"  # the builds' leftovers: images no tag uses (the layer cache stays)
}

in_app() { podman run --rm --network host --no-healthcheck "$APP" python -c "$1"; }

database() {  # the stack's own database in the machine's Postgres (trust auth on loopback)
  in_app "
import psycopg
with psycopg.connect('host=127.0.0.1 user=postgres dbname=postgres', autocommit=True) as db:
    if not db.execute('SELECT 1 FROM pg_database WHERE datname = %s', ['$DATABASE']).fetchone():
        db.execute('CREATE DATABASE $DATABASE')
        print('created database $DATABASE')"
}

compose() {
  podman-compose --podman-path "$HERE/podman-hostnet" -p "$PROJECT" -f "$CACHE/compose.yml" "$@" >>"$LOG" 2>&1 \
    || { tail -n 15 "$LOG" >&2; return 1; }
}

port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

wait_healthy() { wait_healthy_named "${PROJECT}_$1_1" "$2"; }

wait_healthy_named() {  # podman runs no healthcheck timers without systemd: run the checks here
  local name=$1 deadline=$((SECONDS + $2))
  until podman healthcheck run "$name" >/dev/null 2>&1; do
    [ $SECONDS -lt "$deadline" ] || die "$name not healthy after $2 s (see: podman logs $name)"
    sleep 2
  done
  say "$name healthy"
}

up() {
  need_packages
  base_image
  wheelhouse
  build_images
  compose_file
  compose down -t 20 || true
  for port in "$PORT" "$S3_PORT"; do port_free "$port" || die "port $port is in use"; done
  database
  # In order, each once the one before is healthy: podman-compose 1.0.3 ignores depends_on conditions.
  compose up -d minio && wait_healthy minio 60
  compose up -d minio-init
  [ "$(podman wait "${PROJECT}_minio-init_1")" = 0 ] || die "minio-init failed (podman logs ${PROJECT}_minio-init_1)"
  compose up -d api && wait_healthy api 180
  compose up -d worker && wait_healthy worker 120
  say "up: http://127.0.0.1:$PORT/ (log: $LOG)"
}

extra_worker() {  # README's "worker on another host", here: its own container, no volume, same services
  local name=${PROJECT}-worker-${1:?a name}
  podman image exists "$APP" || die "no $APP: run 'make compose-up' first"
  [ -f "$CACHE/compose.yml" ] || compose_file
  local env=() key
  [ -f "$ROOT/.env" ] && set -a && . "$ROOT/.env" && set +a  # the key `make compose-up` generated
  while IFS= read -r key; do env+=(-e "$key"); done < <(python3 "$HERE/local_compose.py" --env worker "$CACHE/compose.yml")
  podman run -d --name "$name" --hostname "$name" --network host --cpus 2 --restart unless-stopped \
    --health-cmd "python -m worker.health" --health-interval 30s --health-start-period 30s \
    --label "io.podman.compose.project=$PROJECT" --label com.docker.compose.service=worker \
    "${env[@]}" "$APP" guided-sfm worker >>"$LOG" 2>&1
  wait_healthy_named "$name" 120
  say "worker $name started (podman logs $name)"
}

compose_file() {
  python3 "$HERE/local_compose.py" "$ROOT/docker-compose.yml" "$PG_URL" "$BROKER_URL" "$S3_PORT" "$PORT" \
    >"$CACHE/compose.yml"
}

down() {
  command -v podman-compose >/dev/null || { say "podman-compose is not installed: nothing runs"; return; }
  compose_file
  compose down -t 20
  podman ps -aq --filter "label=io.podman.compose.project=$PROJECT" | xargs -r podman rm -f -t 20 >/dev/null
  podman network rm -f "${PROJECT}_default" >/dev/null 2>&1 || true  # made by podman-compose, unused
  if [ "${1:-}" = --purge ]; then
    podman volume ls -q | grep "^${PROJECT}_" | xargs -r podman volume rm -f >/dev/null
    in_app "
import psycopg, redis
redis.Redis.from_url('$BROKER_URL').flushdb()
with psycopg.connect('host=127.0.0.1 user=postgres dbname=postgres', autocommit=True) as db:
    db.execute('DROP DATABASE IF EXISTS $DATABASE')"
    say "purged: volumes, database $DATABASE, $BROKER_URL"
  fi
  say "down"
}

case "${1:-}" in
  up) up ;;
  down) shift; down "$@" ;;
  worker) extra_worker "${2:-}" ;;
  *) die "usage: $0 up | down [--purge] | worker NAME" ;;
esac
