"""A benchmark protocol for a measured record: fixed ranges, a state window, RMSE after it.

Why its own module: published results on a real record (the Silverbox's) are
comparable only under that record's protocol — the training range for every
modelling choice, free-run simulation of each test set, the first ``window``
output samples for the initial state alone, and the score on what follows.
The bench's own fits (:func:`msd_bench.core.identification.identify.evaluate`)
keep their default 300-sample window; this module states the protocol's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import identify
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Protocol:
    """Half-open sample ranges of a record's sets and the initial-state window."""

    name: str
    dt: float
    """Sample time, s."""
    train: tuple[int, int]
    """The range every modelling choice is made on."""
    validation_split: float
    """Fraction of the training range at its end held out for validation (fits use the rest)."""
    tests: dict[str, tuple[int, int]]
    """Test sets: reported, never used to choose."""
    window: int = 50
    """Output samples of a set that may initialise the state; scores start after them."""


SILVERBOX = Protocol(
    name="silverbox", dt=2.0**14 / 1e7, train=(40650, 105712), validation_split=0.2,
    tests={"multisine": (105712, 127400), "arrow_full": (100, 40575), "arrow_no_extrapolation": (100, 32100)},
)
"""The Silverbox benchmark (Wigren & Schoukens, ECC 2013): fs = 10^7/2^14 Hz, the official split."""


def estimation_and_validation(proto: Protocol, u: FloatArray, y: FloatArray) -> tuple[IOData, IOData]:
    """The training range split into the part models are fitted on and the held-out end."""
    a, b = proto.train
    if b > u.size or u.size != y.size:
        raise InvalidInputError(f"{proto.name}: record of {u.size} samples is shorter than its training "
                                f"range [{a}, {b}) or u and y differ in length")
    cut = b - round(proto.validation_split * (b - a))
    est = IOData((Experiment(u[a:cut], y[a:cut], "estimation"),), proto.dt)
    val = IOData((Experiment(u[cut:b], y[cut:b], "validation"),), proto.dt)
    return est, val


def rmse_after_window(model: StepModel, exp: Experiment, window: int) -> float:
    """Free-run RMSE on ``exp`` after its first ``window`` samples, which alone set the initial state.

    A simulation that leaves the finite numbers scores ``inf`` (it is reported, not hidden).
    """
    try:
        sim = identify.free_run(model, exp, "estimate", horizon=window)
    except InvalidInputError:
        return math.inf
    err = sim[window:] - exp.y[window:]
    value = float(np.sqrt(np.mean(err**2)))
    return value if math.isfinite(value) else math.inf


def score_tests(model: StepModel, proto: Protocol, u: FloatArray, y: FloatArray) -> dict[str, float]:
    """RMSE (record units) on every test set of ``proto``."""
    return {name: rmse_after_window(model, Experiment(u[a:b], y[a:b], name), proto.window)
            for name, (a, b) in proto.tests.items()}
