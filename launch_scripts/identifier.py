"""Identify GLM / PLM / NLARX surrogates from experiment bags and write model artifacts.

    python launch_scripts/identifier.py --ros-args -p bags_dir:=bags/<run>/excitation \
        -p out_dir:=bags/<run>/models
    # a rig's bags:
    python launch_scripts/identifier.py --ros-args -p broad_bag:=/data/broad \
        -p validation_bag:=/data/val -p "models:=[glm,nlarx-improved]" -p out_dir:=models
"""

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.identifier_node import IdentifierNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(IdentifierNode)
