"""Make one agent kind's policy through its design, then validate it on the plant topics.

    python launch_scripts/agent.py --ros-args -p model_path:=bags/<run>/models/plm.json \
        -p out_dir:=bags/<run>/agents/plm -p "seeds:=[0,1,2]" [-p via_ros:=true] [-p kind:=plm+improved]
    # a kind made on the plant itself needs no model (Dyna-Q interacts with the plant node):
    python launch_scripts/agent.py --ros-args -p kind:=dyna-q -p out_dir:=bags/<run>/agents/dyna-q
    # the job bench.py wrote (one JSON file: msd_bench.app.job; a -p given beside it wins):
    python launch_scripts/agent.py --ros-args -p job:=bags/<run>/jobs/agent-plm.json

``kind`` (default ``plm``, the paper agent) takes one agent kind of the design registry
(msd_bench.designs.registry.AGENT_KINDS): ``<model>`` or ``<model>+<design>`` over a model kind
of the identifier (``plm+improved``, ``glm+pid``, ``nlarx-paper+robust``, ``plm@toward``, ...),
or an on-plant learner (``plant``, ``plant+<design>``, ``dyna-q``); anything else is one
ConfigError line naming the kinds. The kind chooses the design: there is no ``agent``
parameter, and an unknown parameter is refused. Every parameter is a field of
msd_bench.nodes.agent_node.AgentNodeConfig.

Defaults of the run's quantities (episodes, plant_episodes, steps, validation_steps, window, target,
dt, force, shaping, planning_steps) are the run configuration's (msd_bench.app.job.SHARED_DEFAULTS).
Which budget a kind spends is its design's rule: ``episodes`` on a model, ``plant_episodes`` for a
kind that learns on the plant node itself (``dyna-q``, ``plant+dqn``).
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
