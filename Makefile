# The two commands a newcomer needs: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
# Re-install whenever the package metadata or a compiled kernel's C source changes.
STAMP_RUN  := $(VENV)/.stamp-run
STAMP_DEV  := $(VENV)/.stamp-dev
INSTALL_DEPS := pyproject.toml setup.py $(wildcard src/parolkit/*/*.c)

.PHONY: run test test-fast soak lint bench screenshot clean venv ros-venv browser-deps

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

$(STAMP_RUN): $(INSTALL_DEPS) | $(PY)
	$(PY) -m pip install -q -e .
	touch $@

$(STAMP_DEV): $(INSTALL_DEPS) | $(PY)
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP_RUN) $@

venv: $(STAMP_RUN)

## make run: set everything up and start the commander with the simulated robot
run: $(STAMP_RUN)
	$(VENV)/bin/parolkit gui --sim

## make ros-venv: the isolated ROS 2 Jazzy environment (rclpy from PyPI) of tests/integration/test_ros2.py;
## ROS is never a dependency of parolkit itself
# the ROS 2 Jazzy wheels on PyPI are built for CPython 3.11 (cp311, manylinux_2_28 x86_64)
ROS_PYTHON ?= python3.11
VENV_ROS  := .venv-ros
# (the stamp is renamed whenever ROS_PKGS grows, so an existing .venv-ros gets the new packages)
STAMP_ROS := $(VENV_ROS)/.stamp-ros-2
ROS_PKGS  := ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp ros-jazzy-std-msgs ros-jazzy-sensor-msgs ros-jazzy-trajectory-msgs ros-jazzy-test-msgs

$(STAMP_ROS):
	$(ROS_PYTHON) -m venv $(VENV_ROS)
	$(VENV_ROS)/bin/python -m pip install -q $(ROS_PKGS)
	touch $@

ros-venv: $(STAMP_ROS)

## the browser tests' headless Chromium (Debian's) and axe-core (npm), installed if missing
browser-deps:
	./scripts/ensure-chromium.sh
	./scripts/ensure-axe.sh

## make test: set everything up, lint and type-check, and run every test (unit, integration, browser).
## The set-up jobs run side by side (the dev virtualenv then lint; the ROS 2 virtualenv; Chromium
## and axe-core). Then TEST_WORKERS processes in parallel (pytest-xdist, each test module in one
## process, the longest modules first, a browser module beside a module of another kind whenever one is
## left: tests/conftest.py module_order, the times in tests/module_seconds.json written by scripts/test-durations),
## then the tests marked alone on their own (only the 20,000 datagrams/s flood of test_flood_estop,
## which takes the whole machine)
TEST_WORKERS ?= 2
test:
	$(MAKE) -j3 --no-print-directory lint ros-venv browser-deps
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder -m "not soak and not alone"
	$(PY) -m pytest -q -m alone

## make lint: ruff (style, imports, bugs) and mypy --strict (types, the whole package);
## the import-cycle check is a unit test (tests/unit/test_import_cycles.py)
lint: $(STAMP_DEV)
	$(VENV)/bin/ruff check src tests bench
	$(VENV)/bin/mypy

## make soak: the 10-minute timing run under two CPU hogs (tests/integration/test_timing_under_load.py,
## marked soak: make test leaves it out); PAROLKIT_LOAD_TEST_S=120 shortens it
soak: $(STAMP_DEV)
	$(PY) -m pytest -q -m soak

## make test-fast: unit tests only
test-fast: $(STAMP_DEV)
	$(PY) -m pytest -q tests/unit

## make screenshot: regenerate docs/images/commander*.png with the browser test suite
screenshot: $(STAMP_DEV) browser-deps
	PAROLKIT_UPDATE_SCREENSHOT=1 $(PY) -m pytest -q tests/browser

## make bench: run every benchmark script and print its figures
bench: $(STAMP_DEV)
	for b in bench/[!_]*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) $(VENV_ROS) build *.egg-info src/*.egg-info .pytest_cache
	find src -name '*.so' -delete
