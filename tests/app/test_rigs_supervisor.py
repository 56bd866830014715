"""``msd-bench rigs --supervisor on``: each validation run on a rig goes through the supervisor's
compiled filter (told the nominal plant), and rigs.json/rigs.md carry the runs' risk."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from msd_bench.cli import main as cli_main
from msd_bench.core.learning.qconfig import QConfig, packed
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PRESETS
from msd_bench.core.rigs.population import draw
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_loop import run_on_rig
from msd_bench.core.safety.supervisor import SupervisorOptions

RIGS = ["rigs", "--rigs", "1", "--seeds", "1", "--agents", "glm", "--episodes", "3", "--steps", "200",
        "--samples", "500", "--val-samples", "400", "--validation-steps", "300", "--bootstrap", "100",
        "--workers", "1", "--supervisor", "on"]


def test_a_supervised_sweep_records_risk_in_rigs_json_and_md(tmp_path: Path) -> None:
    assert cli_main([*RIGS, "--out", str(tmp_path / "r")]) == 0
    doc = json.loads((tmp_path / "r" / "rigs.json").read_text())
    risk = doc["kinds"][0]["risk"]
    assert risk["runs"] == 1 and risk["contacts"] == 0
    outcome = doc["rigs"][0]["outcomes"][0]
    assert set(outcome["risk"]) >= {"contacts", "peak_x", "override_share", "overrides", "aborted"}
    md = (tmp_path / "r" / "rigs.md").read_text()
    assert "| Stop contacts (runs) |" in md and "behind the safety supervisor" in md
    assert doc["validation"]["supervisor"] is True


def test_a_table_pushing_into_a_stop_is_held_off_it_on_a_population_rig() -> None:
    spec = draw(1000)
    cfg = QConfig()
    q = np.zeros((packed(cfg).enc.n_states, 5))
    q[:, 4] = 1.0  # greedy: always +F
    out = {}
    for side, lim in (("off", None), ("on", SupervisorOptions().limits(PRESETS["default"]))):
        rig = Rig(spec.params, spec.imperfections, 0)
        out[side] = run_on_rig(rig, q, cfg, plant_model(spec.params), 1.0, 1500, np.random.default_rng(0),
                               limits=lim)
    assert np.abs(out["off"].x).max() == spec.params.x_max  # the stop
    assert np.abs(out["on"].x).max() < 2.25 + SupervisorOptions().limits(PRESETS["default"]).margin
    assert out["on"].reason is not None and (out["on"].reason > 0).any() and out["off"].reason is None

