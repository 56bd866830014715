"""A plant-like model as data: the handle every surrogate and the plant share.

A :class:`StepModel` is what Q-learning trains on, what the surrogate node
serves and what the identifier writes: a kernel kind, its packed parameters
(see :mod:`msd_bench.core.physics.kernels`), the sample time and force limit of the
plant it stands for, and a little metadata. Keeping models as plain arrays
makes them cheap to save, hash, and step in compiled code.

Every stepping method goes through the compiled :func:`kernels.advance`, so the
model contract is the kernel's: a non-finite force raises
:class:`InvalidInputError`, a force beyond ±``force_limit`` acts as the bound,
and the output stays on the stroke.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.layouts import COEF_MAX, check_params
from msd_bench.core.physics.plant import DT, PlantParams

if TYPE_CHECKING:  # python-control is heavy: loaded only when a transfer function is asked for
    import control

    from msd_bench.core.identification.linear import LinearFit

FloatArray = NDArray[np.float64]

DT_MAX = 1e3
"""Longest sample time, s, a model may state (every fit uses the rig's 0.01 s)."""

NOMINAL_FORCE = PlantParams().F
"""Force limit of a surrogate whose maker does not say: the nominal plant's F."""


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
    dt: float = DT
    """Sample time in s of one step (for the plant: its ``dt`` parameter, which must agree)."""
    force_limit: float = NOMINAL_FORCE
    """Forces saturate to ±force_limit N before they act, as on the plant the model stands
    for (for the plant: its ``F`` parameter, which must agree)."""
    kernel: kernels.Kernel = field(init=False, repr=False, compare=False)
    """The model as compiled code takes it (built from the fields above)."""

    def __post_init__(self) -> None:
        if self.kind not in kernels.KIND_NAMES:
            raise InvalidInputError(f"unknown model kind {self.kind}; known: {kernels.KIND_NAMES}")
        try:
            p = np.ascontiguousarray(self.params, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            raise InvalidInputError(f"model {self.name!r}: parameters must be numbers") from None
        if p.ndim != 1 or not np.all(np.isfinite(p)):
            raise InvalidInputError(f"model {self.name!r}: parameters must be a finite 1-D array")
        for what, value, hi in (("dt", self.dt, DT_MAX), ("force_limit", self.force_limit, COEF_MAX)):
            if not (math.isfinite(value) and 0 < value <= hi):
                raise InvalidInputError(f"model {self.name!r}: {what} must be in (0, {hi:g}], "
                                        f"got {value}")
        if self.kind == kernels.KIND_HELD:
            _check_held(p, self.name)
        else:
            check_params(kernels.KIND_NAMES[self.kind], p, self.name)
        if self.kind in PLANT_LIKE:
            _check_plant(p, self.dt, self.force_limit)
        object.__setattr__(self, "params", p)
        object.__setattr__(self, "kernel",
                           kernels.Kernel(self.kind, p, float(self.force_limit)))

    @property
    def state_kind(self) -> int:
        """The kind whose state layout this model's state has (a held model's inner kind)."""
        return int(self.params[1]) if self.kind == kernels.KIND_HELD else self.kind

    @property
    def x_max(self) -> float:
        """Upper stroke limit the model's output is projected on (a held model's: its inner one's)."""
        kind, p = self.kind, self.params
        if kind == kernels.KIND_HELD:
            kind, p = int(p[1]), p[kernels.HELD_HEAD:]
        return 0.5 * float(p[5] if kind in PLANT_LIKE else p[0])

    def initial_state(self) -> FloatArray:
        """Rest at the origin (the paper's episodes start from x = 0, v = 0), actuator idle."""
        return np.zeros(state_size(self.state_kind))

    def step(self, state: FloatArray, u: float) -> float:
        """Advance ``state`` in place under force ``u``; return the new position."""
        return float(kernels.advance(self.kernel, state, float(u)))

    def simulate(self, u: FloatArray, state: FloatArray | None = None) -> FloatArray:
        """Free-run response to ``u`` from ``state`` (rest if None); ``x[0]`` is the start."""
        u = _as_signal(u, "force")
        s = self.initial_state() if state is None else _as_state(state, state_size(self.state_kind))
        return kernels.rollout(self.kernel, u, s)

    def predict_one_step(self, x: FloatArray, u: FloatArray) -> FloatArray:
        """One-step-ahead prediction from the measured history (ARX-type models)."""
        if self.kind in PLANT_LIKE or self.kind == kernels.KIND_HELD:
            raise InvalidInputError("one-step prediction needs an ARX-type model, not a plant-structure "
                                    "or held one")
        x, u = _as_signal(x, "position"), _as_signal(u, "force")
        if x.shape != u.shape:
            raise InvalidInputError(f"position and force lengths differ: {x.size} vs {u.size}")
        return kernels.one_step(self.kernel, x, u)

    def linear_fit(self) -> LinearFit:
        """The linear model's coefficients as a :class:`LinearFit` (linear kernel kind only).

        Why here: a user holding a loaded artifact should not have to know the
        packed layout ``[L, n1, n2, d1, d2, u0, y0]`` to reach python-control.
        """
        if self.kind != kernels.KIND_LINEAR:
            raise InvalidInputError(
                f"model {self.name!r} is of kind {kernels.KIND_NAMES[self.kind]}: only a linear model "
                "(the GLM) has a transfer function")
        from msd_bench.core.identification.linear import LinearFit

        _, n1, n2, d1, d2, u0, y0 = (float(v) for v in self.params)
        return LinearFit(n1, n2, d1, d2, u0, y0, self.dt, method=str(self.info.get("method", "oe")))

    def to_transfer_function(self) -> control.TransferFunction:
        """Discrete ``G(z) = (n1 z + n2) / (z^2 + d1 z + d2)`` with the model's ``dt``.

        It maps deviations of the force from ``u0`` to deviations of the position
        from ``y0`` (the operating point in ``info``; the paper's GLM has both 0),
        and knows nothing of the stroke limits or the force saturation.
        """
        return self.linear_fit().to_transfer_function()

    def to_continuous(self) -> control.TransferFunction:
        """The continuous-time transfer function whose zero-order-hold image is this model."""
        return self.linear_fit().to_continuous()


MAX_HELD = 10_000
"""Most samples one decision may be held over (a 10 ms decision on a 1 MHz rig)."""


def held(model: StepModel, n: int) -> StepModel:
    """``model`` stepped ``n`` times under each command: the model a learner deciding every ``n`` rig
    samples sees (issue 37 item 3: the command held between decisions). ``dt`` is the decision
    period; ``model`` itself when ``n`` is 1, so a run deciding every sample is unchanged bit for bit.
    """
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_HELD:
        raise InvalidInputError(f"samples per decision must be a whole number in [1, {MAX_HELD}], got {n!r}")
    if n == 1:
        return model
    if model.kind == kernels.KIND_HELD:
        raise InvalidInputError(f"model {model.name!r} is held already")
    params = np.concatenate([[float(n), float(model.kind)], model.params])
    return StepModel(kernels.KIND_HELD, params, model.name, {**model.info, "held_samples": n},
                     model.dt * n, model.force_limit)


def _check_held(p: FloatArray, name: str) -> None:
    """A held model's head (whole n in [2, MAX_HELD], a known inner kind that is not held) and its inner
    parameters against the inner kind's layout."""
    if p.size <= kernels.HELD_HEAD:
        raise InvalidInputError(f"model {name!r} (held): no inner model")
    n, inner = float(p[0]), float(p[1])
    if n != int(n) or not 2 <= n <= MAX_HELD:
        raise InvalidInputError(f"model {name!r} (held): samples per decision must be whole, "
                                f"in [2, {MAX_HELD}]")
    if inner != int(inner) or int(inner) not in kernels.KIND_NAMES or int(inner) == kernels.KIND_HELD:
        raise InvalidInputError(f"model {name!r} (held): unknown inner kind {inner:g}")
    check_params(kernels.KIND_NAMES[int(inner)], p[kernels.HELD_HEAD:], name)


def check_rate(model: StepModel, dt: float, where: str) -> None:
    """Refuse, in one line, a model that steps at another sample time than ``where`` runs at.

    A model's coefficients hold only at the rate it was identified at: stepping it at another
    would silently run it faster or slower than the rig (models are never resampled).
    """
    if not math.isclose(model.dt, dt, rel_tol=1e-9):
        raise InvalidInputError(
            f"model {model.name!r} was identified at dt {model.dt:g} s ({1 / model.dt:g} Hz) but {where} "
            f"runs at dt {dt:g} s ({1 / dt:g} Hz); identify it at that rate (models are never resampled)")


PLANT_LIKE = (kernels.KIND_PLANT, kernels.KIND_GREYBOX_RIG, kernels.KIND_RK4)
"""Kernel kinds whose parameters hold a plant's ``L, F, dt`` in slots 5-7 and whose state is
``[x, v, ...]`` (the plant's own ``[m, c, k, g, h, L, F, dt]``; rk4's springs sit in 2-4)."""


def plant_model(params: PlantParams) -> StepModel:
    """The true plant as a :class:`StepModel` (for Dyna-Q and on-plant baselines)."""
    return StepModel(kernels.KIND_PLANT, params.as_array(), name="plant", dt=params.dt,
                     force_limit=params.F)


def _check_plant(p: FloatArray, dt: float, force_limit: float) -> None:
    """A plant model's dt and force limit are its own parameters; a mismatch is a mistake."""
    plant = kernels.Plant(*(float(v) for v in p[:kernels.PLANT_SIZE]))
    if (plant.dt, plant.F) != (dt, force_limit):
        raise InvalidInputError(
            f"plant model: dt={dt}, force_limit={force_limit} disagree with its parameters "
            f"dt={plant.dt}, F={plant.F}; build it with plant_model(params)")


def state_size(kind: int) -> int:
    """Length of a model state of kernel ``kind`` (:func:`kernels.state_size`, the one place it is stated)."""
    return int(kernels.state_size(kind))


def _as_state(state: FloatArray, size: int) -> FloatArray:
    s = np.array(state, dtype=np.float64)
    if s.shape != (size,) or not np.all(np.isfinite(s)):
        raise InvalidInputError(f"model state must be {size} finite values, got {state!r}")
    return s


def _as_signal(a: FloatArray, what: str) -> FloatArray:
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidInputError(f"{what} must be a non-empty 1-D array")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{what} must be finite: it contains a non-finite value")
    return arr
