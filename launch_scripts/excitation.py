"""Play one seeded excitation signal on /msd/force; exits 0 when done.

    python launch_scripts/excitation.py [--ros-args -p signal:=multilevel -p seed:=3 -p lockstep:=true]
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.excitation_node import ExcitationNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(ExcitationNode)
