"""The sample period comes from the bag stamps: another rate or irregular stamps are one-line errors
naming what is wrong (never resampled), and a record may start anywhere (x0 estimated, not 0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.excitation import MultilevelConfig, multilevel
from msd_bench.core.identification.identify import evaluate, free_run
from msd_bench.core.identification.model_kinds import FitRequest, fit_model
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_records import BagRole, load_records
from msd_bench.io.bags.bag_timing import TimingPolicy, check_timing
from msd_bench.io.bags.reader import write_experiment

N = 400


def _bag(path: Path, t: np.ndarray) -> Path:
    rng = np.random.default_rng(1)
    n = t.size
    return write_experiment(path, t, rng.normal(size=n), rng.normal(size=n), np.zeros(n), params={})


def _roles(bag: Path) -> list[BagRole]:
    return [BagRole(bag, "train", None, 0), BagRole(bag, "validation", None, 0)]


def test_period_from_the_stamps_must_be_the_runs_dt_and_names_both(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "at50hz", np.arange(N, dtype=np.int64) * 20_000_000)
    with pytest.raises(BagError) as err:
        load_records(_roles(bag), False, dt=0.01)
    text = str(err.value)
    assert "\n" not in text and str(bag) in text
    assert "20.000 ms apart" in text and "dt is 10.000 ms" in text


def test_a_run_at_another_dt_reads_a_bag_at_that_dt(tmp_path: Path) -> None:
    """The run's dt is a parameter, not the constant 0.01: a 50 Hz run takes a 50 Hz bag."""
    bag = _bag(tmp_path / "at50hz", np.arange(N, dtype=np.int64) * 20_000_000)
    records = load_records(_roles(bag), False, dt=0.02)
    assert records.broad_train.dt == 0.02 and len(records.broad_train.experiments[0]) == N


def test_bunched_stamps_are_irregular(tmp_path: Path) -> None:
    t = np.arange(N, dtype=np.int64) * 10_000_000
    t[200] = t[199] + 2_000_000  # 2 ms after its predecessor (and 18 ms before its successor)
    bag = _bag(tmp_path / "bunched", t)
    with pytest.raises(BagError) as err:
        load_records(_roles(bag), False)
    text = str(err.value)
    assert "\n" not in text and "irregular stamps" in text and "sample 200" in text and "2.000 ms" in text


def test_irregularity_counts_every_bunched_step() -> None:
    t = np.arange(N, dtype=np.int64) * 10_000_000
    t[100] -= 6_000_000
    t[300] -= 7_000_000
    with pytest.raises(BagError, match=r"sample 100 is only 4\.000 ms after sample 99 .*2 such steps"):
        check_timing("b", t, TimingPolicy())


def test_a_record_from_rest_off_zero_is_identified_from_its_estimated_initial_state() -> None:
    """A rig's experiment starts wherever the mass rests (here 0.4 m): the fit's initial state is
    estimated from the record, so the surrogate still reproduces it."""
    p = PlantParams()
    u = multilevel(MultilevelConfig(n_samples=3000), 7)
    u_val = multilevel(MultilevelConfig(n_samples=1500), 8)
    x, _, ua = simulate(u, p)
    xv, _, uva = simulate(u_val, p, x0=0.4)
    broad = IOData((Experiment(u=ua, y=x),), p.dt)
    val = IOData((Experiment(u=uva, y=xv),), p.dt)
    req = FitRequest(Records({}, {}, broad, val), 0, p.L, p.F)
    greybox = fit_model("greybox", req)
    yhat = free_run(greybox, val.experiments[0])  # from the estimated initial state
    assert abs(yhat[0] - 0.4) < 0.01
    assert evaluate(greybox, val).sim_fit > 95.0
    assert evaluate(fit_model("glm", req), val).sim_fit > 60.0  # a linear model fits it too, less well
