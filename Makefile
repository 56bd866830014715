# Each target sets up its own environment first (.venv with everything pinned).
PY := .venv/bin/python
STAMP := .venv/.installed

.PHONY: bench test lint setup

bench: $(STAMP)
	$(PY) launch_scripts/bench.py $(ARGS)

test: $(STAMP)
	$(PY) -m pytest $(ARGS)

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m mypy

setup: $(STAMP)

$(STAMP): pyproject.toml scripts/setup_env.sh
	bash scripts/setup_env.sh
	touch $(STAMP)
