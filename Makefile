# urbanvox: setup, demo and tests. `make demo` and `make test` work on a fresh Debian/Ubuntu
# machine: the first run installs QGIS (apt-get, sudo when not root), makes .venv and a
# project-local QGIS profile (.qgis/) with the plugin enabled; later runs skip what is done.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

SYSTEM_PYTHON ?= /usr/bin/python3
VENV := .venv
PYTHON := $(VENV)/bin/python
ENV := . scripts/env.sh &&
PYTEST_ARGS ?=

# Stamps live beside what they stand for, so deleting .venv or .qgis redoes that step.
SYSTEM_STAMP := .build/system.stamp
VENV_STAMP := $(VENV)/.urbanvox-installed
PLUGIN_STAMP := .qgis/.urbanvox-enabled

.PHONY: help setup demo test test-numpy2 bench package qgis-list clean distclean

help:
	@echo "make demo       set up (QGIS, .venv, plugin) and run both algorithms on a synthetic district"
	@echo "make test       set up and run the whole test suite (core + QGIS)"
	@echo "make test-numpy2  the core's tests on numpy 2 (newer distributions), in .venv-numpy2, no QGIS"
	@echo "make setup      only the setup: QGIS from apt, .venv with pinned deps, plugin enabled in .qgis/"
	@echo "make bench      benchmarks: per-stage time, rate and memory, with baselines (BENCH_ARGS=--quick)"
	@echo "make package    build dist/urbanvox-VERSION.zip, installable with Plugins > Install from ZIP"
	@echo "make qgis-list  list the urbanvox algorithms as qgis_process sees them"
	@echo "make clean      remove .build, .qgis, demo-output; make distclean also removes .venv"

setup: $(SYSTEM_STAMP) $(VENV_STAMP) $(PLUGIN_STAMP)

$(SYSTEM_STAMP): scripts/install-system-deps.sh
	scripts/install-system-deps.sh
	@mkdir -p $(@D) && touch $@

# Pins numpy (and scipy, pyproj) to the versions of the Python QGIS embeds.
constraints.txt: scripts/constraints.py | $(SYSTEM_STAMP)
	$(SYSTEM_PYTHON) scripts/constraints.py > $@.tmp && mv $@.tmp $@

# The venv, then the optional numba kernels compiled once, for both import names of the core
# (core here, urbanvox.core in QGIS): the first reconstruction does not wait for them.
$(VENV_STAMP): requirements.txt requirements-dev.txt constraints.txt | $(SYSTEM_STAMP)
	test -x $(PYTHON) || $(SYSTEM_PYTHON) -m venv --system-site-packages $(VENV)
	$(PYTHON) -m pip install --quiet --disable-pip-version-check -c constraints.txt -r requirements-dev.txt
	$(PYTHON) -c 'import qgis.core, laspy, lazrs, trimesh, shapely, pyproj, scipy, meshio, numpy, pytest; print("venv ok: numpy", numpy.__version__, "laspy", laspy.__version__, "trimesh", trimesh.__version__)'
	$(ENV) $(PYTHON) -m core.jit && PYTHONPATH="$$URBANVOX_ROOT/.build/plugins:$$PYTHONPATH" $(PYTHON) -m urbanvox.core.jit
	touch $@

TRANSLATIONS := $(patsubst %.ts,%.qm,$(wildcard i18n/*.ts))

# Compiled translations, loaded by the plugin for QGIS's locale.
i18n/%.qm: i18n/%.ts | $(SYSTEM_STAMP)
	lrelease -silent $< -qm $@

$(PLUGIN_STAMP): metadata.txt scripts/env.sh $(TRANSLATIONS) | $(SYSTEM_STAMP)
	scripts/qgis-process plugins enable urbanvox >/dev/null 2>&1 || true
	scripts/qgis-process plugins 2>/dev/null | grep -q '^\* urbanvox$$' \
	  || { echo "urbanvox is not loaded by qgis_process; see: scripts/qgis-process plugins" >&2; exit 1; }
	touch $@

demo: setup
	scripts/demo.sh

test: setup
	$(ENV) URBANVOX_REQUIRE_QGIS=1 $(PYTHON) -m pytest tests $(PYTEST_ARGS)

# The core on numpy 2, as newer distributions ship it beside QGIS: a venv of its own (no QGIS,
# so tests/qgis is left out) and a copy of the sources, whose compiled kernels are cached apart
# from those .venv made under numpy 1.
NUMPY2_VENV := .venv-numpy2
NUMPY2_COPY := .build/numpy2
NUMPY2_ENV := URBANVOX_JIT=always PYTHONPATH=. URBANVOX_SHARED_DATA="$${URBANVOX_SHARED_DATA:-$(CURDIR)/../shared/data}"
test-numpy2: | $(SYSTEM_STAMP)
	test -x $(NUMPY2_VENV)/bin/python || $(SYSTEM_PYTHON) -m venv $(NUMPY2_VENV)
	$(NUMPY2_VENV)/bin/python -m pip install --quiet --disable-pip-version-check "numpy>=2" \
	  -r requirements-dev.txt matplotlib
	rm -rf $(NUMPY2_COPY) && mkdir -p $(NUMPY2_COPY)
	tar -c --exclude=./.git --exclude='./.venv*' --exclude=./.build --exclude=./.qgis --exclude=./demo-output \
	  --exclude=./dist --exclude=./test-artifacts --exclude=__pycache__ . | tar -x -C $(NUMPY2_COPY)
	cd $(NUMPY2_COPY) && $(NUMPY2_ENV) $(CURDIR)/$(NUMPY2_VENV)/bin/python -m pytest tests --ignore=tests/qgis \
	  -p no:cacheprovider $(PYTEST_ARGS)

package: $(TRANSLATIONS)
	$(SYSTEM_PYTHON) scripts/package.py

qgis-list: setup
	scripts/qgis-process list 2>/dev/null | sed -n '/^urbanvox/,/^$$/p'

clean:
	rm -rf .build .qgis demo-output .pytest_cache dist

distclean: clean
	rm -rf $(VENV) $(NUMPY2_VENV) constraints.txt

BENCH_ARGS ?=

# Benchmarks are not tests: they print a table and write JSON to benchmarks/results/
bench: setup
	$(PYTHON) -m pip install --quiet --disable-pip-version-check -c constraints.txt -r benchmarks/requirements.txt
	$(PYTHON) -m benchmarks $(BENCH_ARGS)
