"""The main job: the paper on the emulated ROS 2 bench, every stage a real node process.

    python launch_scripts/bench.py                  # lock-step, 3 seeds, report under bags/<run-id>/
    python launch_scripts/bench.py --seeds 20 --realtime
    python launch_scripts/bench.py --live           # watch it in Foxglove: ws://127.0.0.1:8765 (docs/live.md)
    python launch_scripts/bench.py --bags bags/<old-run>/excitation --stages identify,agents,report

Everything it does is in :mod:`msd_bench.graph.main`.
"""

from __future__ import annotations

import sys

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.graph.main import main

if __name__ == "__main__":
    sys.exit(main())
