"""A rig's own simulator as a model: the ceiling of what any identified surrogate could give an agent.

Why a model and not the rig: every agent design trains on a
:class:`~msd_bench.core.physics.model.StepModel`. The greybox-rig kernel
(``kernels.KIND_GREYBOX_RIG``) already is the rig emulator's actuator (dead
time, then a first-order lag) and Coulomb friction in front of the plant,
driven by the *commanded* force, so filled with a rig's drawn parameters
instead of fitted ones it is that rig's true dynamics and drive: the most a
model can know of it. What it leaves out is the sensor (noise and encoder),
which no surrogate models either: an agent meets it through its observer.
"""

from __future__ import annotations

import numpy as np

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.rig import RigImperfections


def rig_model(params: PlantParams, imperfections: RigImperfections) -> StepModel:
    """The greybox-rig model of a rig with its true plant, friction, lag and delay (one ConfigError
    line when the delay exceeds what the kernel's delay line holds)."""
    if imperfections.delay_samples > kernels.RIG_DELAY_MAX:
        raise ConfigError(f"rig delay {imperfections.delay_samples} samples exceeds the greybox-rig "
                          f"model's {kernels.RIG_DELAY_MAX}")
    p = np.concatenate([params.as_array(), [imperfections.friction, imperfections.actuator_tau,
                                            float(imperfections.delay_samples)]])
    info = {"truth": True, "parameters": {"friction": imperfections.friction,
                                          "tau": imperfections.actuator_tau},
            "delay": imperfections.delay_samples}
    return StepModel(kernels.KIND_GREYBOX_RIG, p, name="truth", info=info, dt=params.dt,
                     force_limit=params.F)
