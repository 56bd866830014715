"""Which integrator a grey-box kind steps with: the plant's kernel, or RK4 on a fast resonance.

Why: ``greybox`` and ``greybox-rig`` step with one semi-implicit Euler step per
sample (the emulated plant's own kernel, and the rig kernel built on it). That
is exact for records the emulator wrote and adequate while the resonance is
slow against the sample rate; the Euler step's frequency error grows like
``(omega dt)^2``, and a real rig sampled near its resonance (the Silverbox:
``omega dt ~ 0.7``) is out of its reach however the parameters are fitted. So
when the record's own linear fit puts ``omega dt`` above
:data:`EULER_OMEGA_DT`, the kind fits the ``rk4`` kernel too
(:mod:`msd_bench.core.identification.greybox_rk4`, the same physical family:
mass, damping, springs, friction, offset) and keeps whichever fits the
*training* record better in free run; the choice and both costs are recorded
in the model file (``info["integrator_choice"]``). At or below the limit nothing
else is fitted: the emulator's records (``omega dt`` below 0.05 on the default
plant and its rig population) keep their models bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.greybox_rk4 import Rk4Config, identify_greybox_rk4, linear_start
from msd_bench.core.physics.model import StepModel

EULER_OMEGA_DT = 0.2
"""Largest ``omega_n dt`` (the training record's linear resonance times its sample time) at which a
grey-box kind steps with its Euler kernel alone. The Euler step's relative frequency error is about
``(omega dt)^2 / 24``: 0.17 % here, against ~2 % at the Silverbox's 0.7, which no parameter fit
undoes on a lightly damped resonance. A design constant, not tuned on any test set."""


def omega_dt(train: IOData) -> float:
    """``omega_n dt`` of the training record's second-order linear fit (its natural resonance per sample)."""
    return float(linear_start(train).wn * train.dt)


def with_integrator_choice(train: IOData, euler_fit: Callable[[], StepModel],
                           stroke: float, force: float) -> StepModel:
    """The Euler-kernel fit of ``kind``, or the rk4 fit when the resonance is fast and rk4 fits better."""
    wdt = omega_dt(train)
    euler = euler_fit()
    fact: dict[str, Any] = {"omega_dt": wdt, "euler_limit": EULER_OMEGA_DT}
    if not wdt > EULER_OMEGA_DT:
        return _noted(euler, {**fact, "chosen": "euler", "reason": "omega dt within the Euler limit"})
    rk4 = identify_greybox_rk4(train, Rk4Config(stroke=stroke, force=force))
    costs = {"euler": _train_rms(euler), "rk4": _train_rms(rk4)}
    chosen = "rk4" if costs["rk4"] < costs["euler"] else "euler"
    fact.update(chosen=chosen, train_rms=costs,
                reason="omega dt above the Euler limit: the lower free-run RMS on the training record")
    winner = rk4 if chosen == "rk4" else euler
    seconds = float(euler.info.get("fit_seconds", 0.0)) + float(rk4.info.get("fit_seconds", 0.0))
    return _noted(winner, fact, fit_seconds=seconds)


def _train_rms(model: StepModel) -> float:
    rms = model.info.get("train_rms")
    return float(rms) if isinstance(rms, (int, float)) and math.isfinite(rms) else math.inf


def _noted(model: StepModel, fact: dict[str, Any], fit_seconds: float | None = None) -> StepModel:
    """``model`` with the choice in its info (and the summed fit time when two fits ran); the kind's
    name is :func:`~msd_bench.core.identification.model_kinds.fit_model`'s to set."""
    info = {**model.info, "integrator_choice": fact}
    if fit_seconds is not None:
        info["fit_seconds"] = fit_seconds
    return replace(model, info=info)
