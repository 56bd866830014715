"""The rk4 kernel and the grey-box for real rigs (greybox-rk4): integrator, input structures, fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.identification import greybox_rk4 as g
from msd_bench.core.identification import identify
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel

DT = 0.01


def _params(m: float = 1.0, c: float = 0.5, k1: float = 4.0, k2: float = 0.0, k3: float = 0.0,
            f0: float = 0.0, fc: float = 0.0, interp: int = 0, substeps: int = 1) -> np.ndarray:
    return np.array([m, c, k1, k2, k3, 100.0, 50.0, DT, 0.0, 0.0, fc, 0.01, f0, substeps, interp])


def test_rk4_matches_the_exact_free_response_of_a_linear_oscillator() -> None:
    """RK4's local error is O(h^5): at omega dt = 0.7 the free response stays within 1e-3 of the exact one."""
    wn, zeta, dt = 70.0, 0.05, 0.01
    p = _params(m=1.0, c=2 * zeta * wn, k1=wn**2)
    p[7] = dt
    x = kernels.rk4_simulate(p, np.zeros(200), 1.0, 0.0, 0.0)
    wd = wn * math.sqrt(1 - zeta**2)
    t = np.arange(200) * dt
    exact = np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert np.max(np.abs(x - exact)) < 2e-2
    p[13] = 4  # four substeps: error down by ~4^4
    x4 = kernels.rk4_simulate(p, np.zeros(200), 1.0, 0.0, 0.0)
    assert np.max(np.abs(x4 - exact)) < np.max(np.abs(x - exact)) / 50


def test_the_kernel_step_is_the_fitter_simulation_and_the_ramp_starts_from_the_last_command() -> None:
    p = _params(k3=2.0, k2=-0.5, f0=0.3, interp=1)
    model = StepModel(kernels.KIND_RK4, p, "rk4", dt=DT, force_limit=50.0)
    u = np.sin(np.arange(300) * 0.07) * 3.0
    s = model.initial_state()
    stepped = [s[0]] + [model.step(s, float(v)) for v in u[:-1]]
    assert np.allclose(stepped, kernels.rk4_simulate(p, u, 0.0, 0.0, 0.0), rtol=0, atol=1e-14)
    held = StepModel(kernels.KIND_RK4, _params(k3=2.0, k2=-0.5, f0=0.3, interp=0), "rk4", dt=DT,
                     force_limit=50.0)
    assert not np.allclose(held.simulate(u), model.simulate(u))


@pytest.mark.parametrize(("slot", "value", "what"), [(0, 0.0, "m"), (13, 0.0, "substeps"),
                                                     (13, 2.5, "substeps"), (14, 2.0, "interp"),
                                                     (10, -1.0, "fc"), (11, 0.0, "vc")])
def test_a_bad_rk4_parameter_is_named(slot: int, value: float, what: str) -> None:
    p = _params()
    p[slot] = value
    with pytest.raises(InvalidInputError, match=f"\\({what}\\)"):
        StepModel(kernels.KIND_RK4, p, "rk4", dt=DT, force_limit=50.0)


def _record(p: np.ndarray, n: int, seed: int, lead: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = np.convolve(rng.normal(0, 6.0, n + 20), np.ones(5) / 5, mode="same")[:n]
    fed = g.fed_input(u, lead)
    y = kernels.rk4_simulate(p, fed, 0.05, 0.0, float(u[0]))
    return IOData((Experiment(u, y + rng.normal(0, 1e-4, n), "sim"),), DT)


def test_fit_recovers_a_duffing_with_signed_terms_and_picks_the_ramp() -> None:
    truth = _params(m=0.8, c=0.6, k1=5.0, k2=-1.5, k3=8.0, f0=-0.4, interp=1)
    model = g.identify_greybox_rk4(_record(truth, 3000, 1, lead=1), g.Rk4Config(stroke=100.0, force=50.0))
    info = model.info
    assert info["structure"] == "ramp" and info["input_lead"] == 1
    for name, value in (("m", 0.8), ("c", 0.6), ("k1", 5.0), ("k2", -1.5), ("k3", 8.0), ("f0", -0.4)):
        assert info["parameters"][name] == pytest.approx(value, rel=0.03, abs=0.03), name
        assert 0 < info["stderr"][name] < 0.05 * max(abs(value), 1.0), name
    assert info["fixed"] == ["ks", "gs", "fc"]
    val = _record(truth, 1500, 2, lead=1)
    assert identify.evaluate(model, val, horizon=50, skip=50).sim_fit > 98.0


def test_springless_stage_is_a_member_of_the_family() -> None:
    truth = _params(m=2.0, c=1.5, k1=0.0, f0=0.2, fc=0.3)
    cfg = g.springless(g.Rk4Config(stroke=100.0, force=50.0), coulomb=True)
    model = g.identify_greybox_rk4(_record(truth, 3000, 3), cfg)
    par = model.info["parameters"]
    assert par["k1"] == par["k3"] == 0.0 and "k1" in model.info["fixed"]
    assert par["m"] == pytest.approx(2.0, rel=0.05) and par["c"] == pytest.approx(1.5, rel=0.1)
    assert par["fc"] == pytest.approx(0.3, rel=0.1) and par["f0"] == pytest.approx(0.2, rel=0.1)
    assert model.info["structure"] == "hold"


def test_bounds_hold_and_fixed_values_stay() -> None:
    truth = _params(m=0.8, c=0.6, k1=5.0, k3=8.0)
    specs = {**g.Rk4Config().params, "k3": g.ParamSpec(0.0, 2.0), "c": g.ParamSpec(fixed=True, value=0.7)}
    cfg = g.Rk4Config(stroke=100.0, force=50.0, params=specs, structures=("hold",), starts=(1.0,))
    model = g.identify_greybox_rk4(_record(truth, 1500, 4), cfg)
    assert 0.0 <= model.info["parameters"]["k3"] <= 2.0
    assert model.info["parameters"]["c"] == 0.7


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"params": {"spring": g.ParamSpec()}}, "unknown parameter"),
    ({"params": {"k1": g.ParamSpec(2.0, 1.0)}}, "bounds are invalid"),
    ({"params": {"c": g.ParamSpec(fixed=True)}}, "fixed but has no value"),
    ({"params": {"m": g.ParamSpec(-1.0, 1.0)}}, "minimum must be >= 0"),
    ({"structures": ("foh",)}, "structures must be"),
    ({"substeps": 0}, "substeps must be"),
    ({"starts": ()}, "starts must be"),
])
def test_bad_config_is_one_line(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match) as err:
        g.Rk4Config(**kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(err.value)
