# Everything the project needs is installed from here: a fresh clone runs `make test` / `make nightly`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: test test-slow lint nightly bench install clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[engines,distributed,models,test]"
	touch $(STAMP)

install: $(STAMP)

# One pytest worker per core (pytest-xdist), tests handed out as workers free up: the suite is
# CPU-bound, and its tests are independent of the load beside them.
test: $(STAMP) lint
	$(BIN)/python -m pytest -q -n auto --dist worksteal

# ruff's lint and format (pyproject.toml says which rules and why): part of `make test`.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

# The long studies `make test` leaves out (marked slow: every scheme's kernel on every scene, every
# engine mode's own build, model-file and cluster nightlies, a bisection over releases).
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m slow

bench: $(STAMP)
	$(BIN)/harness bench

clean:
	rm -rf $(VENV) results

nightly: $(STAMP)
	$(BIN)/harness nightly --suite standard
