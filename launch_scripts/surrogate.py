"""Serve an identified model artifact as a plant-like node under /surrogate/<model name>.

    python launch_scripts/surrogate.py --ros-args -p model_path:=bags/<run>/models/plm.json \
        -p lockstep:=true [-r __ns:=/surrogate/plm]
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.spin import run
from msd_bench.nodes.surrogate_node import build_surrogate

if __name__ == "__main__":
    run(build_surrogate)
