"""Start the rig emulator: the NL-MSD as real hardware shows it, real time, under /rig by default.

    python launch_scripts/rig.py [--ros-args -p sensor_noise:=0.0 -p delay_samples:=2 -r __ns:=/rig]

``-p live_port:=PORT`` also serves the live view from this process: a Foxglove WebSocket server on
ws://127.0.0.1:PORT with the rows decimated to 50 Hz and the set-point (0: a free port, logged;
docs/live.md).

No reset, no lock-step, no /clock; every imperfection is a parameter (docs/rig.md §Parameters).
``-p population_seed:=N`` serves member N of the rig population (docs/rig.md §Population);
explicit parameters still win.
``-p interface:=ros2_control`` shows the face of a forward effort controller and a joint state
broadcaster instead (docs/ros2-control.md §Emulator).
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.rig_node import build_rig
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(build_rig)
