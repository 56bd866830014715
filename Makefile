# Each target sets up its own environment first (a venv with everything pinned).
# DISTRO picks the ROS 2 distribution: kilted (default, .venv), jazzy (.venv-jazzy) or
# system (.venv-system: an apt-installed ROS 2 sourced in this shell); docs/distributions.md.
DISTRO ?= kilted
VENV := $(if $(filter kilted,$(DISTRO)),.venv,.venv-$(DISTRO))
PY := $(VENV)/bin/python
# Parallel pytest-xdist workers for `make test` (docs/testing.md §Workers); most of the suite waits
# on processes, discovery and real time, so more workers than cores pay. JOBS= runs one process.
JOBS ?= -n 3 --dist loadfile
STAMP := $(VENV)/.installed

.PHONY: bench test lint setup

bench: $(STAMP)
	$(PY) launch_scripts/bench.py $(ARGS)

test: $(STAMP)
	$(PY) -m pytest $(JOBS) $(ARGS)

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m mypy

# Also records $(VENV) as the environment the launch scripts re-execute into.
setup: $(STAMP)
	@echo $(VENV) > .msd-env

$(STAMP): pyproject.toml scripts/setup_env.sh
	bash scripts/setup_env.sh $(DISTRO)
	touch $(STAMP)
