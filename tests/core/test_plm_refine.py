"""The PLM's global refinement on its exact Jacobian by Levenberg–Marquardt (core/identification/lm.py):
the README's
identification seeds fit as with least_squares' trf before, and the shared optimiser on its own."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.app.pipeline import records_from_plan
from msd_bench.app.plan import paper_plan
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import lm
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.identify import PlmConfig, evaluate, identify_plm
from msd_bench.core.identification.plm import EXACT_MAX_ITER
from msd_bench.core.physics import plant

TRF_BROAD_FIT = {0: 97.181701, 1: 96.524977}
"""Broad validation fits of the exact refinement by trf (the code before core/identification/lm.py),
seeds 0 and 1."""


@pytest.mark.parametrize("seed", sorted(TRF_BROAD_FIT))
def test_the_ideal_plants_fits_are_unchanged_and_converge_under_the_cap(seed: int) -> None:
    p = plant.preset("default")
    records = records_from_plan(p, paper_plan(seed))
    model = identify_plm(records.bias_train, PlmConfig(stroke=p.L))
    refinement = model.info["refinement"]
    assert refinement["kept"]
    assert refinement["nfev"] < EXACT_MAX_ITER  # converged, not stopped by the cap
    assert evaluate(model, records.broad_val).sim_fit == pytest.approx(TRF_BROAD_FIT[seed], abs=0.01)


def _rosenbrock(z: np.ndarray) -> np.ndarray:
    return np.array([10.0 * (z[1] - z[0] ** 2), 1.0 - z[0]])


def _rosenbrock_jac(z: np.ndarray, _r: np.ndarray) -> tuple[np.ndarray, int]:
    return np.array([[-20.0 * z[0], 10.0], [-1.0, 0.0]]), 1


def test_levenberg_marquardt_finds_the_minimum_and_keeps_to_its_bounds() -> None:
    inf = np.full(2, np.inf)
    z, cost, _ = lm.levenberg_marquardt(_rosenbrock, _rosenbrock_jac, np.array([-1.2, 1.0]), -inf, inf, 200,
                                        rel_stop=0.0)
    np.testing.assert_allclose(z, [1.0, 1.0], atol=1e-6)
    assert cost < 1e-12
    hi = np.array([0.5, np.inf])
    z, _, _ = lm.levenberg_marquardt(_rosenbrock, _rosenbrock_jac, np.array([-1.2, 1.0]), -inf, hi, 200)
    assert z[0] <= 0.5 and z[0] == pytest.approx(0.5, abs=1e-3)


def test_forward_differences_match_the_exact_jacobian() -> None:
    z = np.array([0.3, -0.7])
    jac, used = lm.forward_differences(_rosenbrock, np.full(2, np.inf), 1e-7)(z, _rosenbrock(z))
    assert used == 2
    np.testing.assert_allclose(jac, _rosenbrock_jac(z, _rosenbrock(z))[0], rtol=1e-5, atol=1e-6)


def _try_record(p: plant.PlantParams, target: float, steps: int) -> IOData:
    """A closed-loop try on ``p``: a saturating PD law on the measured position, as an agent's run
    records it (the applied force and the measured position, here noiseless)."""
    x, v, us, ys = 0.0, 0.0, [], []
    for _ in range(steps):
        u = float(np.clip(8.0 * (target - x) - 4.0 * v + 2.4 * np.sin(target), -p.F, p.F))
        x, v = plant.step(x, v, u, p)
        us.append(u)
        ys.append(x)
    return IOData((Experiment(np.array(us), np.array(ys), name="try"),), p.dt)


def test_a_closed_loop_try_joins_the_blend_refinement_and_is_fitted_better() -> None:
    p = plant.preset("default")
    records = records_from_plan(p, paper_plan(2, samples=3000, val_samples=1000, settle=300))
    tried = _try_record(p, 1.2, 1500)
    before = identify_plm(records.bias_train, PlmConfig(stroke=p.L))
    after = identify_plm(records.bias_train, PlmConfig(stroke=p.L), closed_loop=[tried, tried])
    assert "2 closed-loop records" in after.info["refinement"]["method"] and after.info["refinement"]["kept"]
    assert after.info["n_samples"] == before.info["n_samples"] + 2 * 1500
    assert evaluate(after, tried).sim_fit > evaluate(before, tried).sim_fit
    with pytest.raises(InvalidInputError, match="does not refine"):
        identify_plm(records.bias_train, PlmConfig(stroke=p.L, refine=False), closed_loop=[tried])
