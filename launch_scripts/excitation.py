"""Play one seeded excitation signal on /msd/force; exits 0 when done.

    python launch_scripts/excitation.py [--ros-args -p signal:=multilevel -p seed:=3 -p lockstep:=true]
"""

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.excitation_node import ExcitationNode
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(lambda: ExcitationNode())
