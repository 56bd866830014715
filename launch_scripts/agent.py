"""Train a Q-learning agent on a surrogate, then validate it on the plant topics.

    python launch_scripts/agent.py --ros-args -p model_path:=bags/<run>/models/plm.json \
        -p out_dir:=bags/<run>/agents/plm -p "seeds:=[0,1,2]" [-p via_ros:=true] [-p agent:=improved]
"""

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.agent_node import AgentNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(AgentNode)
