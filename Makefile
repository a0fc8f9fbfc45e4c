# Two commands do all the set-up: `make run` (serve the sample project) and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin

.PHONY: install run demo test lint bench

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	touch $@

install: $(BIN)/.installed

run: install
	$(BIN)/guided-sfm demo

demo: install
	$(BIN)/guided-sfm demo

test: install
	$(BIN)/python -m pytest

lint: install
	$(BIN)/ruff check services worker tests benchmarks migrations

bench: install
	$(BIN)/python benchmarks/bench_pruning.py
