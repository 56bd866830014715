"""The improved NLARX's noise prefilter stays off a record whose motion reaches past its cut-off."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.identification.data import Experiment
from msd_bench.core.identification.nlarx import NlarxConfig, fit_nlarx, power_band_hz

DT = 0.01


def _record(hz: float, noise: float, seed: int = 0) -> Experiment:
    rng = np.random.default_rng(seed)
    t = np.arange(4000) * DT
    u = np.sin(2 * np.pi * hz * t) + 0.3 * np.sin(2 * np.pi * 0.5 * hz * t)
    y = 0.5 * np.sin(2 * np.pi * hz * t - 0.3) + rng.normal(0.0, noise, t.size)
    return Experiment(u, y, "sines")


def test_power_band_is_where_the_output_lives() -> None:
    assert power_band_hz((_record(1.0, 0.0),), DT) == pytest.approx(1.0, abs=0.05)
    assert power_band_hz((_record(12.0, 0.0),), DT) == pytest.approx(12.0, abs=0.05)


@pytest.mark.parametrize(("hz", "filtered"), [(1.0, True), (12.0, False)])
def test_prefilter_only_below_its_cut_off(hz: float, filtered: bool) -> None:
    cfg = NlarxConfig(form="improved", one_step_iters=2, sim_iters=0)
    _, info = fit_nlarx((_record(hz, 0.01),), 5.0, cfg, DT)
    assert info["noise_ratio"] > cfg.prefilter_above  # type: ignore[operator]  # noisy enough to filter either way
    assert (info["prefilter_hz"] == cfg.prefilter_hz) is filtered
    assert info["output_band_hz"] == pytest.approx(hz, abs=0.1)
