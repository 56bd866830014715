"""A plant-like model as data: the handle every surrogate and the plant share.

A :class:`StepModel` is what Q-learning trains on, what the surrogate node
serves and what the identifier writes: a kernel kind, its packed parameters
(see :mod:`msd_bench.core.kernels`) and a little metadata. Keeping models as
plain arrays makes them cheap to save, hash, and step in compiled code.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core import kernels
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.plant import PlantParams

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StepModel:
    """A discrete-time plant-like model stepped by :func:`kernels.advance`."""

    kind: int
    """Kernel kind (``kernels.KIND_*``)."""
    params: FloatArray
    """Packed parameters in the kernel's layout."""
    name: str = ""
    """Human label, e.g. ``"glm"``, ``"plm"``, ``"nlarx-paper"``."""
    info: dict[str, Any] = field(default_factory=dict)
    """Free-form facts worth reporting (fit %, sample counts, coefficients)."""

    def __post_init__(self) -> None:
        if self.kind not in kernels.KIND_NAMES:
            raise InvalidInputError(f"unknown model kind {self.kind}")
        p = np.ascontiguousarray(self.params, dtype=np.float64)
        if p.ndim != 1 or not np.all(np.isfinite(p)):
            raise InvalidInputError(f"model {self.name!r}: parameters must be a finite 1-D array")
        object.__setattr__(self, "params", p)

    @property
    def x_max(self) -> float:
        """Upper stroke limit the model's output is projected on."""
        return 0.5 * float(self.params[5] if self.kind == kernels.KIND_PLANT else self.params[0])

    def initial_state(self) -> FloatArray:
        """Rest at the origin (the paper's episodes start from x = 0, v = 0)."""
        return np.zeros(4)

    def step(self, state: FloatArray, u: float) -> float:
        """Advance ``state`` in place under force ``u``; return the new position."""
        return float(kernels.advance(self.kind, self.params, state, float(u)))

    def simulate(self, u: FloatArray, state: FloatArray | None = None) -> FloatArray:
        """Free-run response to ``u`` from ``state`` (rest if None); ``x[0]`` is the start."""
        u = _as_signal(u, "force")
        s = self.initial_state() if state is None else np.array(state, dtype=float)
        return kernels.rollout(self.kind, self.params, u, s)

    def predict_one_step(self, x: FloatArray, u: FloatArray) -> FloatArray:
        """One-step-ahead prediction from the measured history (ARX-type models)."""
        if self.kind == kernels.KIND_PLANT:
            raise InvalidInputError("one-step prediction needs an ARX-type model, not the plant")
        x, u = _as_signal(x, "position"), _as_signal(u, "force")
        if x.shape != u.shape:
            raise InvalidInputError(f"position and force lengths differ: {x.size} vs {u.size}")
        return kernels.one_step(self.kind, self.params, x, u)


def plant_model(params: PlantParams) -> StepModel:
    """The true plant as a :class:`StepModel` (for Dyna-Q and on-plant baselines)."""
    return StepModel(kernels.KIND_PLANT, params.as_array(), name="plant")


def _as_signal(a: FloatArray, what: str) -> FloatArray:
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidInputError(f"{what} must be a non-empty 1-D array")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{what} contains a non-finite value")
    return arr
