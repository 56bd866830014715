"""Start the safety supervisor between a controller (pointed at /supervised) and a plant.

    python launch_scripts/supervisor.py [--ros-args -p plant_ns:=/rig -p options_file:=opts.json
        -p interface:=ros2_control -r __ns:=/supervised]

What it guards and why: docs/supervisor.md. E-stop: ``ros2 topic pub --once /supervised/estop
std_msgs/msg/Empty``; clear with the latch count it reports on /diagnostics.
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.spin import run
from msd_bench.nodes.supervisor_node import build_supervisor

if __name__ == "__main__":
    run(build_supervisor)
