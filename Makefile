# Two commands do all the set-up: `make run` (serve the sample project) and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin
POSTGRES_TEST_URL ?= postgresql+psycopg://postgres@127.0.0.1:5432/postgres

.PHONY: install run demo test lint bench compose-up compose-down

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	touch $@

install: $(BIN)/.installed

run: install
	$(BIN)/guided-sfm serve --sample

demo: install
	$(BIN)/guided-sfm demo

# Everything on the embedded default (SQLite, filesystem broker; Redis and Chromium tests run
# where those exist), then the database-backed tests again on Postgres when it answers.
test: install
	$(BIN)/python -m pytest --durations=25
	@if $(BIN)/python -c "import psycopg; psycopg.connect('host=127.0.0.1 user=postgres dbname=postgres', connect_timeout=3).close()" 2>/dev/null; then \
		echo "--- again on Postgres ---"; \
		GUIDED_SFM_TEST_DATABASE_URL=$(POSTGRES_TEST_URL) $(BIN)/python -m pytest tests/api tests/worker tests/test_migrations.py -m "not slow and not browser"; \
	elif [ "$$GUIDED_SFM_REQUIRE_SERVICES" = 1 ]; then \
		echo "--- Postgres not reachable on 127.0.0.1:5432 and GUIDED_SFM_REQUIRE_SERVICES=1: failing ---"; exit 1; \
	else echo "--- Postgres not reachable on 127.0.0.1:5432: its pass is skipped ---"; fi

lint: install
	$(BIN)/ruff check services worker tests benchmarks migrations deploy

bench: install
	$(BIN)/python benchmarks/bench_pruning.py
	$(BIN)/python benchmarks/bench_rule.py

# The compose stack, detached (README, "Deployment"): docker compose, else podman with this
# machine's override. `make compose-down` stops it; the volumes stay.
compose-up:
	deploy/compose.sh up

compose-down:
	deploy/compose.sh down
