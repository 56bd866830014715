"""The default plant's fits hold (issue 33 item 6): on identification seeds 0-2 no kind's simulation
fit drops more than 0.5 points below the fit stored before the issue (docs/results/
identification_speed_seed{0,1,2}.json, written by benchmarks/bench_identification_rig.py).

The GLM, the grey-box and the improved NLARX (the form this issue may change) run in the default
suite; the PLM, the greybox-rig and the paper NLARX (seconds each, code this issue leaves alone)
in the slow tier. The rk4 grey-box is new: it has no earlier figure to hold to.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from msd_bench.app.pipeline import records_from_plan
from msd_bench.app.plan import paper_plan
from msd_bench.core.identification.identify import evaluate
from msd_bench.core.identification.integrator_choice import EULER_OMEGA_DT, omega_dt
from msd_bench.core.identification.model_kinds import FitRequest, fit_model
from msd_bench.core.identification.records import Records
from msd_bench.core.physics import kernels, plant

RESULTS = Path(__file__).resolve().parents[2] / "docs" / "results"
SEEDS = (0, 1, 2)
_RECORDS: dict[int, Records] = {}


def _stored(seed: int) -> dict[str, float]:
    doc = json.loads((RESULTS / f"identification_speed_seed{seed}.json").read_text())
    return {kind: float(row["sim_fit"]) for kind, row in doc["new"]["kinds"].items()}


def _records(seed: int) -> Records:
    if seed not in _RECORDS:
        _RECORDS[seed] = records_from_plan(plant.preset("default"), paper_plan(seed))
    return _RECORDS[seed]


def _fit(kind: str, seed: int) -> float:
    params = plant.preset("default")
    records = _records(seed)
    model = fit_model(kind, FitRequest(records, seed, params.L, params.F))
    if kind == "greybox":  # the emulator's slow resonance: the plant's own kernel, nothing else fitted
        assert model.kind == kernels.KIND_PLANT
        assert model.info["integrator_choice"]["chosen"] == "euler"
        assert "train_rms" not in model.info["integrator_choice"]
    return evaluate(model, records.broad_val).sim_fit


@pytest.mark.parametrize("seed", SEEDS)
def test_the_default_plants_resonance_is_far_inside_the_euler_limit(seed: int) -> None:
    assert omega_dt(_records(seed).broad_train) < EULER_OMEGA_DT / 4


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", ["glm", "greybox", "nlarx-improved"])
def test_default_kinds_hold_their_fits(kind: str, seed: int) -> None:
    assert _fit(kind, seed) >= _stored(seed)[kind] - 0.5


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", ["plm", "greybox-rig", "nlarx-paper"])
def test_other_kinds_hold_their_fits(kind: str, seed: int) -> None:
    assert _fit(kind, seed) >= _stored(seed)[kind] - 0.5
