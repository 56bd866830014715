"""Train a Q-learning agent on a surrogate, then validate it on the plant topics.

    python launch_scripts/agent.py --ros-args -p model_path:=bags/<run>/models/plm.json \
        -p out_dir:=bags/<run>/agents/plm -p "seeds:=[0,1,2]" [-p via_ros:=true] [-p agent:=improved]
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.agent_node import AgentNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(AgentNode)
