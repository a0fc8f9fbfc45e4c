# One image for the api and worker services of docker-compose.yml.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1 \
    GUIDED_SFM_DATA_DIR=/data

# libgomp1: OpenMP runtime of the pycolmap wheel
RUN apt-get update && apt-get install -y --no-install-recommends libgomp1 \
    && rm -rf /var/lib/apt/lists/*

WORKDIR /app
COPY pyproject.toml README.md ./
COPY services ./services
COPY worker ./worker
COPY migrations ./migrations
COPY frontend ./frontend
# Editable, so migrations/ and frontend/ are found next to the package as in a checkout.
RUN pip install -e .

RUN useradd --create-home --uid 1000 app && mkdir -p /data && chown app /data
USER app
VOLUME ["/data"]
EXPOSE 8000
CMD ["guided-sfm", "api", "--host", "0.0.0.0", "--port", "8000"]
