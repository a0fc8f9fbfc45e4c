# One image for the api and worker services of docker-compose.yml.
# A normal Docker host builds it as is; deploy/podman/ builds it on a machine with no registry by
# passing its own BASE_IMAGE and a wheelhouse (PIP_NO_INDEX, PIP_FIND_LINKS).
ARG BASE_IMAGE=python:3.11-slim
FROM ${BASE_IMAGE}

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 \
    GUIDED_SFM_DATA_DIR=/data PATH=/opt/venv/bin:$PATH

# libgomp1: OpenMP runtime of the pycolmap wheel (a base image may ship it already)
RUN dpkg -s libgomp1 >/dev/null 2>&1 || { apt-get update \
    && apt-get install -y --no-install-recommends libgomp1 && rm -rf /var/lib/apt/lists/*; }

# pip reads these when the build passes them (a wheelhouse instead of the index).
ARG PIP_NO_INDEX
ARG PIP_FIND_LINKS

WORKDIR /app
# The dependencies first, in their own layer: a change of code or docs does not reinstall them.
COPY pyproject.toml ./
RUN python3 -m venv /opt/venv \
    && python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']))" \
       > /tmp/requirements.txt \
    && pip install -r /tmp/requirements.txt && rm /tmp/requirements.txt
COPY services ./services
COPY worker ./worker
COPY migrations ./migrations
COPY frontend ./frontend
COPY README.md ./
# Editable, so migrations/ and frontend/ are found next to the package as in a checkout.
RUN pip install -e . --no-deps

# /data: the embedded default's data dir. With GUIDED_SFM_ARTIFACTS_URL (compose) it holds nothing of
# a project and jobs work in the temp dir's scratch, so it is no volume: mount one where it is used.
RUN useradd --create-home --uid 1000 app && mkdir -p /data && chown app /data
USER app
EXPOSE 8000
HEALTHCHECK --interval=10s --timeout=5s --start-period=20s --retries=12 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/v1/health', timeout=3)"]
CMD ["guided-sfm", "api", "--host", "0.0.0.0", "--port", "8000"]
