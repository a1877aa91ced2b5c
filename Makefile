# Quick start on a fresh Debian machine: `make bench` and `make test`. Each sets everything up first.
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.ldbench-installed
PYTEST_ARGS ?= -q

.PHONY: bench test setup clean
setup: $(STAMP)

# setuptools prints an advisory for every editable install of a package-dir mapping (the layers live
# under one import name, ldbench; tests/test_imports.py guards the layout): filtered by its text.
$(STAMP): pyproject.toml scripts/system-deps.sh
	bash scripts/system-deps.sh
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	PYTHONWARNINGS='ignore:Editable installation' $(PY) -m pip install -q -e '.[test]'
	touch $@

bench: $(STAMP)
	$(VENV)/bin/ldbench run suites/default.toml --out runs/default

test: $(STAMP)
	$(PY) -m pytest $(PYTEST_ARGS) tests

clean:
	rm -rf $(VENV) .cache runs/default
