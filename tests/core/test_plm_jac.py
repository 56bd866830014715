"""The compiled PLM free run and its exact Jacobian against the code they replace.

``plm_jac.free_run_jac`` must reproduce the kernel's free run (what
``plm._free_run`` computes) to the last bits, and its Jacobian must agree with
central differences of that free run, including where the blend switches
local models and where the output sits at a stop.
"""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.identification import plm_jac
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.linear import LinearFit
from msd_bench.core.identification.plm import _free_run, blend, refine_global
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel

DT = 0.01


def _model(stroke: float = 5.0) -> StepModel:
    """Five stable, different local models with increasing centres, as a fit would give."""
    rng = np.random.default_rng(3)
    local = []
    for i, bias in enumerate((-10.0, -5.0, 0.0, 5.0, 10.0)):
        d1, d2 = -1.95 + 0.01 * i, 0.952 - 0.002 * i
        n1, n2 = 4e-4 * (1 + 0.1 * rng.standard_normal()), 4e-4
        local.append(LinearFit(n1, n2, d1, d2, bias, -1.6 + 0.8 * i, DT))
    return blend(local, stroke, centres=[f.y0 for f in local])


def _experiment(n: int = 1500, seed: int = 0, amp: float = 10.0) -> Experiment:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-amp, amp, n // 50 + 1), 50)[:n]
    y = kernels.rollout(_model().kernel, u, np.array([0.0, 0.0, 0.0, 0.0]))
    return Experiment(u, y + 1e-3 * rng.standard_normal(n), "test")


def _refined_slots() -> np.ndarray:
    return np.array([1 + kernels.PLM_LOCAL_SIZE * i + j for i in range(5) for j in plm_jac.REFINED])


def test_compiled_free_run_is_the_kernels_free_run() -> None:
    m, e = _model(), _experiment()
    y, _ = plm_jac.free_run_jac(m.params, e.u, 0.1, 0.12, float(e.u[0]), m.force_limit, False)
    np.testing.assert_array_equal(y, _free_run(m, e, 0.1, 0.12))


def test_compiled_free_run_holds_at_the_stop_like_the_kernel() -> None:
    m, e = _model(stroke=2.0), _experiment(amp=10.0)
    y, jac = plm_jac.free_run_jac(m.params, e.u, 0.0, 0.0, float(e.u[0]), m.force_limit, True)
    np.testing.assert_array_equal(y, _free_run(m, e, 0.0, 0.0))
    at_stop = np.abs(y) == 1.0
    assert at_stop.sum() > 10  # the case is exercised
    assert np.all(jac[at_stop] == 0.0)


def test_exact_jacobian_matches_central_differences() -> None:
    m, e = _model(), _experiment(n=800)
    p, slots = np.array(m.params), _refined_slots()
    _, jac = plm_jac.free_run_jac(p, e.u, 0.05, 0.06, float(e.u[0]), m.force_limit, True)
    for col, slot in enumerate(slots):  # atol: kinks where the position crosses a centre
        h = 1e-6 * max(abs(p[slot]), 1e-3)
        hi, lo = p.copy(), p.copy()
        hi[slot] += h
        lo[slot] -= h
        yh, _ = plm_jac.free_run_jac(hi, e.u, 0.05, 0.06, float(e.u[0]), m.force_limit, False)
        yl, _ = plm_jac.free_run_jac(lo, e.u, 0.05, 0.06, float(e.u[0]), m.force_limit, False)
        fd = (yh - yl) / (2 * h)
        np.testing.assert_allclose(jac[:, col], fd, rtol=1e-4, atol=1e-5 * np.abs(fd).max())
    for col, step in ((plm_jac.N_FREE, np.array([1e-6, 0.0])), (plm_jac.N_FREE + 1, np.array([0.0, 1e-6]))):
        ah, bh = np.array([0.05, 0.06]) + step
        al, bl = np.array([0.05, 0.06]) - step
        yh, _ = plm_jac.free_run_jac(p, e.u, ah, bh, float(e.u[0]), m.force_limit, False)
        yl, _ = plm_jac.free_run_jac(p, e.u, al, bl, float(e.u[0]), m.force_limit, False)
        fd = (yh - yl) / 2e-6
        np.testing.assert_allclose(jac[:, col], fd, rtol=1e-4, atol=1e-5 * np.abs(fd).max())


@pytest.mark.parametrize("jacobian", ["exact", "finite-difference"])
def test_both_refinements_lower_the_blends_free_run_cost(jacobian: str) -> None:
    m = _model()
    records = [IOData((_experiment(n=1200, seed=s),), DT) for s in range(2)]
    start = StepModel(m.kind, m.params * np.where(np.arange(m.params.size) % 6 == 3, 1.0005, 1.0),
                      name="plm", info=dict(m.info))
    refined, ref = refine_global(start, records, max_nfev=30, jacobian=jacobian)  # type: ignore[arg-type]
    assert ref.kept and ref.cost_after < 0.5 * ref.cost_before
    assert refined.params.size == m.params.size
