# Two commands set everything up on a fresh machine with Python 3.11, make and a C compiler:
#   make demo        creates .venv, installs wiithrow, runs the simulated system with its dashboard
#   make test        creates .venv, installs wiithrow with its test extras, runs the linters and the whole suite
# and, for a developer:
#   make lint        ruff (lint and format), import-linter (the layers), mypy (types)
#   make test-fast   the suite without the slow and the browser tests
#   make format      let ruff format the tree
#   make docs        the documentation site into site/ (mkdocs.yml; strict: a broken link, anchor or reference fails)
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test test-fast lint format clean warm-up docs

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# setuptools prints an "Editable installation" notice on every editable install of this layout (the
# wiithrow/ links resolved by its meta path finder): information, not a fault, and a newcomer's install
# should print nothing but faults.
QUIET_EDITABLE := PYTHONWARNINGS="ignore:Editable installation"

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(QUIET_EDITABLE) $(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(QUIET_EDITABLE) $(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@ $(VENV)/.installed

demo: $(VENV)/.installed
	$(BIN)/wiithrow demo

lint: $(VENV)/.installed-test
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports --no-cache
	$(BIN)/mypy

format: $(VENV)/.installed-test
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

# Four workers on the two cores: many tests wait on real time or on a subprocess, and a waiting test
# holds a worker, not a core (three left the machine idle part of the time; five starved the
# real-time hand of test_check_driver.py: docs/journal.md). Each test module runs on one worker (its
# module fixtures built once); the modules go out longest first by their recorded seconds
# (tests/conftest.py, tests/module_seconds.json), the browser modules first, together, on one
# worker: their pages draw at most FRAME_PERIOD_MS apart on plain scenes (tests/conftest.py:
# FEWER_FRAMES, PLAIN_SCENE), so that Chromium's software rendering leaves room for the others.
# `python -m pytest tests/...` alone still runs serially.
XDIST := -n 4 --dist loadfile

# What every worker and subprocess of the suite would compile for itself (the modules' bytecode, the
# numba kernels), compiled once: beside the linters, which use one core (tests/warm_up.py).
warm-up: $(VENV)/.installed-test
	$(BIN)/python -m tests.warm_up

# The site, strictly: a broken link, anchor, API reference or placeholder fails (mkdocs.yml).
# NO_MKDOCS_2_WARNING: Material's banner about MkDocs 2, printed on every build, is not ours to act on.
docs: $(VENV)/.installed-test
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

test: $(VENV)/.installed-test
	$(MAKE) --no-print-directory -j2 --output-sync=target lint warm-up docs
	$(BIN)/python -m pytest $(XDIST)

test-fast: warm-up
	$(BIN)/python -m pytest $(XDIST) -m "not slow and not browser"

clean:
	rm -rf $(VENV) build site *.egg-info
