# Quick start on a fresh Debian machine: `make bench` and `make test`. Each sets everything up first.
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.ldbench-installed
# -n auto: one pytest worker a core (pytest-xdist); --timeout: a hung test fails with its stack instead of
# stalling the run.
PYTEST_ARGS ?= -q -n auto --dist worksteal --timeout 600

.PHONY: bench test test-slow test-all typecheck setup clean
setup: $(STAMP)

$(STAMP): pyproject.toml scripts/system-deps.sh
	bash scripts/system-deps.sh
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $@

bench: $(STAMP)
	$(VENV)/bin/ldbench run suites/default.toml --out runs/default

# mypy reads pyproject's [tool.mypy]: every ldbench.* import resolves from the checkout, and the annotated
# code type-checks.
typecheck: $(STAMP)
	$(VENV)/bin/mypy

# Two tiers: `make test` (the fast tier, every test not marked slow) and `make test-slow` (the tests marked
# `slow`: paper-scale accuracy and Ray cluster set-ups that cannot be made cheap). CI runs both: make test-all.
test: typecheck
	$(PY) -m pytest $(PYTEST_ARGS) tests

test-slow: $(STAMP)
	LDBENCH_SLOW=1 $(PY) -m pytest $(PYTEST_ARGS) -m slow tests

test-all: test test-slow

clean:
	rm -rf $(VENV) .cache runs/default
