# Quick start on a fresh Debian machine: `make bench` and `make test`. Each sets everything up first.
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.ldbench-installed
# One pytest worker a core plus one (pytest-xdist): tests that wait on a subprocess, a sleep or a Ray worker
# leave a core idle otherwise (on 2 cores: 242 s with 3 workers, 259 s with 2). --timeout: a hung test
# fails with its stack instead of stalling the run.
JOBS   ?= $(shell echo $$(( $$(nproc) + 1 )))
PYTEST_ARGS ?= -q -n $(JOBS) --dist worksteal --timeout 600

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
# mypy runs beside the tests (its log is printed after them); either failing fails the target.
test: $(STAMP)
	@$(VENV)/bin/mypy > $(VENV)/mypy.log 2>&1 & m=$$!; \
	$(PY) -m pytest $(PYTEST_ARGS) tests; t=$$?; \
	wait $$m; k=$$?; echo "mypy: $$(tail -n 1 $(VENV)/mypy.log)"; [ $$k -eq 0 ] || cat $(VENV)/mypy.log; \
	[ $$t -eq 0 ] && [ $$k -eq 0 ]

test-slow: $(STAMP)
	LDBENCH_SLOW=1 $(PY) -m pytest $(PYTEST_ARGS) -m slow tests

test-all: test test-slow

clean:
	rm -rf $(VENV) .cache runs/default
