"""What the environment steps: a plant-like model in-process, or a node over ROS 2.

A backend knows nothing of rewards, targets or sensors (the environment adds
those): it starts an episode at rest and turns one force into the next true
position, so the same environment code runs on the plant, any surrogate and a
ROS graph.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Protocol

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.physics.model import StepModel, check_rate, plant_model
from msd_bench.core.physics.plant import preset


class Backend(Protocol):
    """One plant-like system the environment drives, one sample per call."""

    dt: float
    """Sample time, s."""
    x_max: float
    """Half stroke, m: positions stay in [-x_max, x_max]."""

    def reset(self) -> float:
        """Bring the system to rest at the start of an episode; return the position there."""

    def step(self, u: float) -> float:
        """Apply force ``u`` (N) over one sample; return the position after it."""

    def close(self) -> None:
        """Release what the backend holds (idempotent)."""


class ModelBackend:
    """A :class:`StepModel` stepped in-process through its compiled kernel.

    The true plant is the model of kind ``plant``; a surrogate is any model
    artifact. Forces beyond ±force_limit act as the bound (the kernel's rule).
    """

    def __init__(self, model: StepModel) -> None:
        self.model = model
        self.dt = float(model.dt)
        self.x_max = model.x_max
        self._state = model.initial_state()
        model.step(model.initial_state(), 0.0)  # compile once, before the first episode

    def reset(self) -> float:
        self._state = self.model.initial_state()
        return float(self._state[0])

    def step(self, u: float) -> float:
        return self.model.step(self._state, u)

    def close(self) -> None:
        pass


def model_backend(model: str | os.PathLike[str] | StepModel | None, plant_preset: str) -> ModelBackend:
    """The true plant of ``plant_preset`` when ``model`` is None, else that model (a path or a model)."""
    if model is None:
        return ModelBackend(plant_model(preset(plant_preset)))
    if isinstance(model, StepModel):
        return ModelBackend(model)
    if not isinstance(model, str | os.PathLike):
        raise InvalidInputError(f"model must be an artifact path or a StepModel, got {type(model).__name__}")
    # only a path needs the artifact reader, which checks the file's every field and the parameter
    # vector against its kind's layout: a crafted file is one ArtifactError line, not a crashed kernel
    from msd_bench.io.storage.artifacts import load_model

    loaded = load_model(Path(model))
    check_rate(loaded, preset(plant_preset).dt, f"the {plant_preset} plant")
    return ModelBackend(loaded)
