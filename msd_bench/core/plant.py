"""The nonlinear mass-spring-damper of the paper (§3.1), as pure functions.

``m x'' = u - c x' - k sin(g x) - h x^3``, integrated by forward Euler
(velocity first, then position with the new velocity), the position projected
on ``[-L/2, L/2]`` and the velocity zeroed when the projection bites. Time is
always passed in as ``dt``: nothing here reads a clock.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, InvalidInputError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PlantParams:
    """Physical parameters of the NL-MSD (docs/design.md §Plant)."""

    m: float = 1.0
    """Mass in kg; > 0."""
    c: float = 1.0
    """Viscous damping in N·s/m; > 0."""
    k: float = 2.4
    """Sinusoidal spring gain in N/m; > 0 (stiffness near 0 is k·g)."""
    g: float = 1.0
    """Spatial frequency of the sinusoidal spring in rad/m; > 0."""
    h: float = 1.0
    """Cubic hardening coefficient in N/m³; > 0."""
    L: float = 5.0
    """Stroke in m: the position is confined to [-L/2, L/2] by hard stops."""
    F: float = 10.0
    """Force magnitude in N: the action alphabet is {-F, -F/2, 0, F/2, F}; commands saturate at ±F."""
    dt: float = 0.01
    """Sample time of the Euler step in s."""

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"plant parameter {name} must be finite and > 0, got {value}")

    @property
    def x_max(self) -> float:
        """Position of the upper hard stop, L/2."""
        return self.L / 2.0

    def actions(self) -> FloatArray:
        """The paper's five-force alphabet {-F, -F/2, 0, F/2, F}."""
        return np.array([-self.F, -self.F / 2, 0.0, self.F / 2, self.F])

    def as_array(self) -> FloatArray:
        """Parameters packed for compiled kernels: [m, c, k, g, h, L, F, dt]."""
        return np.array([self.m, self.c, self.k, self.g, self.h, self.L, self.F, self.dt])


PRESETS: dict[str, PlantParams] = {
    "default": PlantParams(),
    # Nearly linear static map (stiffness 4.9-5.1 N/m over the reachable range):
    # shows when the piecewise model is not needed.
    "mild": PlantParams(k=5.0, h=0.7),
}


def preset(name: str, **overrides: float) -> PlantParams:
    """A named parameter set, optionally with fields overridden."""
    if name not in PRESETS:
        raise ConfigError(f"unknown plant preset {name!r}; choose one of {sorted(PRESETS)}")
    return replace(PRESETS[name], **overrides)


def check_force(u: float, params: PlantParams) -> float:
    """Reject a non-finite force and saturate a finite one to ±F."""
    if not math.isfinite(u):
        raise InvalidInputError(f"force must be finite, got {u}")
    return min(max(u, -params.F), params.F)


def spring_force(x: FloatArray | float, params: PlantParams) -> FloatArray | float:
    """Restoring force k sin(g x) + h x³ (N): the plant's static nonlinearity."""
    return params.k * np.sin(params.g * x) + params.h * np.power(x, 3)


def step(x: float, v: float, u: float, params: PlantParams) -> tuple[float, float]:
    """One Euler step from (x, v) under force u; returns the new (x, v).

    The force is checked (finite) and saturated to ±F before it acts.
    """
    u = check_force(u, params)
    acc = (u - params.c * v - params.k * math.sin(params.g * x) - params.h * x**3) / params.m
    v_new = v + params.dt * acc
    x_free = x + params.dt * v_new
    x_new = min(max(x_free, -params.x_max), params.x_max)
    if x_new != x_free:
        v_new = 0.0
    return x_new, v_new


def step_batch(
    x: FloatArray, v: FloatArray, u: FloatArray, params: PlantParams
) -> tuple[FloatArray, FloatArray]:
    """Vectorized :func:`step` over any number of independent plants."""
    u = np.asarray(u, dtype=float)
    if not np.all(np.isfinite(u)):
        raise InvalidInputError("force must be finite in every element of the batch")
    u = np.clip(u, -params.F, params.F)
    acc = (u - params.c * v - spring_force(x, params)) / params.m
    v_new = v + params.dt * acc
    x_free = x + params.dt * v_new
    x_new = np.clip(x_free, -params.x_max, params.x_max)
    v_new = np.where(x_new != x_free, 0.0, v_new)
    return x_new, v_new


def simulate(
    u: FloatArray, params: PlantParams, x0: float = 0.0, v0: float = 0.0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Drive the plant with the force sequence ``u``.

    Returns ``(x, v, u_applied)`` where ``x[k]`` is the position *before* the
    force ``u[k]`` acts (so ``x[0] = x0``), the sampling a recorder sees: the
    output at k and the command held over [k, k+1).
    """
    u = np.asarray(u, dtype=float)
    if u.ndim != 1 or u.size == 0:
        raise InvalidInputError("force sequence must be a non-empty 1-D array")
    if not np.all(np.isfinite(u)):
        raise InvalidInputError("force sequence contains a non-finite value")
    from msd_bench.core.kernels import simulate_plant

    u_applied = np.clip(u, -params.F, params.F)
    x, v = simulate_plant(params.as_array(), u_applied, x0, v0)
    return x, v, u_applied


def equilibrium(u: float, params: PlantParams) -> float:
    """Static position where the spring balances the constant force u (bisection)."""
    u = check_force(u, params)
    lo, hi = -params.x_max, params.x_max
    f = lambda x: float(spring_force(x, params)) - u  # noqa: E731
    if f(lo) >= 0:
        return lo
    if f(hi) <= 0:
        return hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if f(mid) < 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
