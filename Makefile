# Quick start: `make demo` runs the default scenario, `make test` runs the test suite.
# Each target creates .venv and installs the package (editable) on first use: `make demo` only what
# the demo needs (the `demo` extra: matplotlib), `make test` the test extras.
# `make test` runs two stages and reports both, even when the first fails: the whole suite at the
# newest versions (`make test-newest`), then FLOORS_TESTS in .venv-floors at the lowest versions
# pyproject.toml declares, pinned in requirements/floors.txt (`make test-floors`); it exits nonzero
# when either failed.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_STAMP := $(VENV)/.installed-demo
FLOORS := .venv-floors
FLOORS_STAMP := $(FLOORS)/.installed
# The core at the floors: simulate and its results, so3, outputs, scenarios, the command line, the
# interactive page (plotly). The netCDF reader on corrupted files (tests/test_fuzz.py's subprocess fuzz)
# runs in the newest stage only: at the floors (netCDF4 1.7.1.post1 to 1.7.4 with xarray 2023.1 and
# NumPy 1.24) the netCDF/HDF5 C library segfaults on one mutation of the file this version writes
# (seed 7), where the newest stack raises: found when the issues of this round were merged, still open.
FLOORS_TESTS := tests/test_dependencies.py tests/test_api.py tests/test_so3.py tests/test_outputs.py tests/test_libraries.py \
                tests/test_scenario.py tests/test_cli.py tests/test_view.py

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,plot,validation]"
	touch $(STAMP)

# The demo's own stamp: the package and matplotlib, nothing else (seconds, not minutes). After
# `make test` (a superset) it only records that.
$(DEMO_STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PY) -m venv $(VENV)
	@if [ -f $(STAMP) ] && [ $(STAMP) -nt pyproject.toml ]; then :; \
	else echo "make demo: installing lgvi and matplotlib into $(VENV)"; \
	     $(BIN)/python -m pip install --quiet --disable-pip-version-check -e ".[demo]"; fi
	@touch $(DEMO_STAMP)

# Rebuilt from scratch whenever the floors change (an install would not downgrade a package otherwise).
# uv (from PyPI, into this venv) installs in seconds where pip's resolver takes minutes; wheels only
# (--only-binary): a floor without a wheel for this Python fails here rather than compiling.
$(FLOORS_STAMP): pyproject.toml requirements/floors.txt
	rm -rf $(FLOORS)
	$(PY) -m venv $(FLOORS)
	$(FLOORS)/bin/python -m pip install --quiet uv
	$(FLOORS)/bin/python -m uv pip install --quiet --python $(FLOORS)/bin/python --only-binary :all: --no-binary lgvi \
	    -c requirements/floors.txt -e ".[test,plot]"
	touch $(FLOORS_STAMP)

.PHONY: install demo test test-newest test-floors bench browser docs
install: $(STAMP)

demo: $(DEMO_STAMP)
	$(BIN)/python -m lgvi demo -o lgvi-demo

test:
	@newest=passed; floors=passed; \
	$(MAKE) --no-print-directory test-newest || newest=FAILED; \
	$(MAKE) --no-print-directory test-floors || floors=FAILED; \
	echo "make test: newest versions $$newest; floor versions $$floors"; \
	[ $$newest = passed ] && [ $$floors = passed ]

# The suite on JOBS worker processes (pytest-xdist; 2 by default, the cores of a CI machine: `make test
# JOBS=auto` for one per core, `JOBS=0` for one process without workers). --dist loadfile keeps each test
# file in one worker, so a module's fixtures (the docs site's Sphinx build, which writes docs/gallery/) are
# made once and a file's tests run in their order. Two workers share the one Numba cache: each file is written
# to a temporary name renamed into place, and lgvi holds a lock on a kernel's index while it saves one of its
# signatures (lgvi._jit._install_save_lock; docs/performance.md, "The suite on two workers").
JOBS ?= 2
XDIST = $(if $(filter 0,$(JOBS)),-p no:xdist,-n $(JOBS) --dist loadfile)

test-newest: $(STAMP) browser
	$(BIN)/python -m pytest -q $(XDIST)

# Headless Chromium and its driver for tests/test_view_browser.py: Debian's chromium and
# chromium-driver, installed once when missing (root with apt-get; `apt-get update` only when the
# install fails on stale package lists). Not root: a note, and the browser test skips (fails in CI).
browser:
	@if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then \
	    echo "make browser: chromium or chromedriver missing and not root with apt-get; the browser test" \
	         "will skip (as root: apt-get install chromium chromium-driver)"; \
	else \
	    echo "make browser: installing Debian's chromium and chromium-driver (apt-get)"; \
	    export DEBIAN_FRONTEND=noninteractive; \
	    apt-get install -y -qq chromium chromium-driver >/dev/null 2>&1 \
	    || { apt-get update -qq && apt-get install -y -qq chromium chromium-driver >/dev/null; }; \
	fi

# Its own Numba cache: kernels cached by another Numba version would be recompiled (and the
# shared cache overwritten) on every switch between the two environments. Old releases under newer
# transitive dependencies warn about deprecations (matplotlib 3.7 under pyparsing 3.3): not shown.
test-floors: $(FLOORS_STAMP)
	LGVI_FLOORS=1 NUMBA_CACHE_DIR=$(CURDIR)/$(FLOORS)/numba-cache $(FLOORS)/bin/python -m pytest -q -p no:cacheprovider \
	    -W "ignore::DeprecationWarning" $(XDIST) $(FLOORS_TESTS)

# The documentation site (Sphinx; the `docs` extra, inside `test`) in docs/_build/html, warnings as
# errors. The gallery (sphinx-gallery, docs/_gallery.py) runs the fast examples (--quick); LGVI_DOCS_EXAMPLES=all
# runs every one, none (or a list) fewer; an example not run shows its figure kept in docs/figures/.
docs: $(STAMP)
	$(BIN)/python -m sphinx -b html -W --keep-going -q docs docs/_build/html
	@echo "make docs: open docs/_build/html/index.html"

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
