"""Serve an identified model artifact as a plant-like node under /surrogate/<model name>.

    python launch_scripts/surrogate.py --ros-args -p model_path:=bags/<run>/models/plm.json \
        -p lockstep:=true [-r __ns:=/surrogate/plm]
"""

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.spin import run
from msd_bench.nodes.surrogate_node import build_surrogate

if __name__ == "__main__":
    run(build_surrogate)
