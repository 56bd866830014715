"""Imported first by every launch script, so ``python launch_scripts/<node>.py`` runs as typed.

Puts the repository on ``sys.path`` and, when this interpreter lacks the
project's dependencies, re-executes the script with the project's venv (or
prints one line saying how to build it): see ``msd_bench/_bootstrap.py``. Then confines
the process's DDS to loopback when the discovery range is LOCALHOST (``msd_bench/dds.py``),
before any launch script initialises rclpy.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench._bootstrap import ensure_environment

ensure_environment()

from msd_bench.dds import confine_process  # noqa: E402  (only in the project's environment)

confine_process()
