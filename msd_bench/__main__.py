"""``python -m msd_bench``: the ``msd-bench`` command with whatever ``python`` is at hand.

An interpreter lacking the project's dependencies re-executes with the project's
venv first (``msd_bench/_bootstrap.py``), so this works before the venv is activated.
"""

from msd_bench._bootstrap import ensure_environment

ensure_environment(module="msd_bench")

from msd_bench.cli import main  # noqa: E402  (only after the re-exec above)

raise SystemExit(main())
