# Quick start on a fresh Debian machine: `make bench` and `make test`. Each sets everything up first.
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.ldbench-installed
PYTEST_ARGS ?= -q

.PHONY: bench test typecheck setup clean
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

test: typecheck
	$(PY) -m pytest $(PYTEST_ARGS) tests

clean:
	rm -rf $(VENV) .cache runs/default
