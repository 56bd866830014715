"""The main job: the paper on the emulated ROS 2 bench, every stage a real node process.

    python launch_scripts/bench.py                  # lock-step, 3 seeds, report under bags/<run-id>/
    python launch_scripts/bench.py --seeds 20 --realtime
    python launch_scripts/bench.py --bags bags/<old-run>/excitation --stages identify,agents,report

Everything it does is in :mod:`msd_bench.graph.main`.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.graph.main import main

if __name__ == "__main__":
    sys.exit(main())
