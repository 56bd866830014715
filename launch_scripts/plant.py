"""Start the emulated NL-MSD plant: real-time 100 Hz under /msd by default.

    python launch_scripts/plant.py [--ros-args -p lockstep:=true -p preset:=mild -r __ns:=/msd]

``-p live_port:=PORT`` also serves the live view from this process: a Foxglove WebSocket server on
ws://127.0.0.1:PORT with the rows decimated to 50 Hz and the set-point (0: a free port, logged;
docs/live.md).
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.plant_node import PlantNode, declare_true_plant
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(lambda: PlantNode(declare_true_plant))
