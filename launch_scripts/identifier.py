"""Identify GLM / PLM / NLARX surrogates from experiment bags and write model artifacts.

    python launch_scripts/identifier.py --ros-args -p bags_dir:=bags/<run>/excitation \
        -p out_dir:=bags/<run>/models
    # a rig's bags:
    python launch_scripts/identifier.py --ros-args -p broad_bag:=/data/broad \
        -p validation_bag:=/data/val -p "models:=[glm,nlarx-improved]" -p out_dir:=models
    # bags of a ros2_control rig (joint_states + effort_controller/commands; docs/ros2-control.md):
    python launch_scripts/identifier.py --ros-args -p namespace:=/rig -p interface:=ros2_control \
        -p broad_bag:=/data/broad -p validation_bag:=/data/val -p out_dir:=models
    # the job bench.py wrote (one JSON file: msd_bench.app.job; a -p given beside it wins):
    python launch_scripts/identifier.py --ros-args -p job:=bags/<run>/jobs/identifier.json

Defaults of the run's quantities (dt, force, stroke, nlarx_scale) are the run configuration's
(msd_bench.app.job.SHARED_DEFAULTS). Each model written is announced on stdout as a structured
event line ``[event] {"node": "identifier", "event": "model_saved", ...}``, the end as ``identified``.
"""

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them

import _reexec  # noqa: F401  (the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.identifier_node import IdentifierNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(IdentifierNode)
