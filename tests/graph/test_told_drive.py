"""bench.py --plant-ns tells its agents the drive its own bags show, as ``msd-bench rigs`` does.

The bag is a real-time recording (the helpers of tests/io/test_played_cut.py) whose effort went
through a rig's drive with a dead time of 2 samples and a 30 ms lag: the identifier's reading of
the bags writes ``drive.json`` before any model, the agent job carries it, and the agent node's
design is told it (the robust agent's observer assumes the 2 samples).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from msd_bench import designs
from msd_bench.app.config import RunConfig
from msd_bench.core.rigs.actuation import actuator_force
from msd_bench.graph.bench import BenchConfig, agent_args
from msd_bench.io.bags.bag_records import load_records
from msd_bench.io.bags.drive_file import broad_drive, read_drive, write_drive
from msd_bench.nodes.agent_node import AgentNodeConfig
from msd_bench.nodes.params import config_from_job
from tests.io.test_played_cut import _bag, _played, _three

DELAY, LAG = 2, 0.03
RUN = RunConfig(seeds=1, episodes=3, steps=50, validation_steps=400, window=100, agents=("glm+robust",))


def _rig_effort(rec: dict[str, np.ndarray]) -> np.ndarray:
    """The force a rig with a 2-sample dead time and a 30 ms lag applies for the bag's commands."""
    return actuator_force(rec["applied"], DELAY, LAG, 0.01)


def _job(cfg: BenchConfig, kind: str) -> AgentNodeConfig:
    args = agent_args(cfg, kind)
    assert args[0] == "-p" and args[1].startswith("job:=")
    return config_from_job(args[1].removeprefix("job:="), AgentNodeConfig, "agent")


def test_the_agent_job_carries_the_drive_the_bags_show(tmp_path: Path) -> None:
    bag, _ = _bag(tmp_path / "b", _played(), effort=_rig_effort)
    roles, sources = _three(bag), []  # type: ignore[var-annotated]
    load_records(roles, False, "/rig", sources=sources)
    drive = broad_drive(roles, sources)
    assert drive is not None and drive.delay_samples == DELAY and abs(drive.time_constant_s - LAG) < 0.005
    models = tmp_path / "run" / "models"
    models.mkdir(parents=True)
    write_drive(models, drive)
    assert read_drive(models) == (DELAY, drive.time_constant_s)
    cfg = BenchConfig(run_dir=tmp_path / "run", run=RUN, realtime=True, plant_ns="/rig")
    node = _job(cfg, "glm+robust")
    assert node.drive() == designs.Drive(DELAY, drive.time_constant_s)
    told = designs.agent_kind("glm+robust").design.config(  # type: ignore[attr-defined]
        designs.request("glm+robust", None, node.settings(), node.seeds, node.drive()))
    assert told.obs_delay == DELAY  # what the robust agent's observer now assumes
    # the emulator's own runs, and a node whose bags showed no drive: told nothing
    assert _job(BenchConfig(run_dir=tmp_path / "run", run=RUN), "glm+robust").drive() is None
    write_drive(models, None)
    assert read_drive(models) is None and _job(cfg, "glm+robust").drive() is None
