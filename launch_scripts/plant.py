"""Start the emulated NL-MSD plant: real-time 100 Hz under /msd by default.

    python launch_scripts/plant.py [--ros-args -p lockstep:=true -p preset:=mild -r __ns:=/msd]
"""

import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.plant_node import PlantNode, declare_true_plant
from msd_bench.nodes.spin import run

if __name__ == "__main__":
    run(lambda: PlantNode(declare_true_plant))
