"""bench.py's report: a per-seed row takes the risk its agent's ``result.json`` carries, else the risk
of its validation bag; a bag it cannot read leaves the row without risk ("—"), never a crash."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from msd_bench.core.evaluation.risk import trace_risk
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.safety.adversaries import adversary, run_on_plant
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.graph.bench_report import _with_risk
from msd_bench.io.bags.bag_writer import write_experiment
from msd_msgs_py.contract import PLANT_NAMESPACE

P = PlantParams()
ROW = {"seed": 0, "id_seed": 0, "mae": 0.1, "std": 0.0, "po": 0.0, "ts": 1.0, "ts5": 1.0, "sse": 1.0,
       "success": True}


def _cfg(tmp_path: Path) -> SimpleNamespace:
    return SimpleNamespace(run_dir=tmp_path, namespace=PLANT_NAMESPACE, run=SimpleNamespace(plant=P))


def _bag(tmp_path: Path) -> Path:
    """The validation bag of an always +F run: it touches the +2.5 m stop once."""
    adv = adversary("always_plus", P, 800)
    runs = run_on_plant(P, SupervisorOptions().limits(P), adv, np.zeros((1, 800)), supervised=False)
    t = (np.arange(800) * P.dt * 1e9).astype(np.int64)
    bag = tmp_path / "agents" / "plm" / "validation" / "seed_0"
    return write_experiment(bag, t, runs.force[0], runs.x[0], runs.v[0], params={}, reference=1.0)


def test_a_row_without_risk_takes_its_validation_bags(tmp_path: Path) -> None:
    _bag(tmp_path)
    row = _with_risk(_cfg(tmp_path), "plm", dict(ROW))
    assert row["risk"]["contacts"] == 1 and row["risk"]["peak_x"] == P.x_max
    adv = adversary("always_plus", P, 800)
    x = run_on_plant(P, SupervisorOptions().limits(P), adv, np.zeros((1, 800)), supervised=False).x[0]
    assert row["risk"] == trace_risk(x, P).as_dict()  # what the in-process run records, bit for bit


def test_the_agents_own_record_wins_and_an_unreadable_bag_leaves_none(tmp_path: Path) -> None:
    own = {**ROW, "risk": trace_risk(np.zeros(10), P).as_dict()}
    _bag(tmp_path)
    assert _with_risk(_cfg(tmp_path), "plm", own) is own
    for mcap in (tmp_path / "agents" / "plm" / "validation" / "seed_0").glob("*.mcap"):
        mcap.write_bytes(mcap.read_bytes()[:200])
    assert "risk" not in _with_risk(_cfg(tmp_path), "plm", dict(ROW))
    assert "risk" not in _with_risk(_cfg(tmp_path), "glm", dict(ROW))  # no bag at all
