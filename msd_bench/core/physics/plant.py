"""The nonlinear mass-spring-damper of the paper (§3.1), as pure functions.

``m x'' = u - c x' - k sin(g x) - h x^3``, integrated by forward Euler
(velocity first, then position with the new velocity), the position projected
on ``[-L/2, L/2]`` and the velocity zeroed when the projection bites. Time is
always passed in as ``dt``: nothing here reads a clock.

The transition itself is :func:`msd_bench.core.physics.kernels.plant_step`, the one
definition of the physics: :func:`step`, :func:`step_batch`, :func:`simulate`
and every compiled learner run it, so they cannot drift apart. A non-finite
force raises :class:`InvalidInputError` on every path; a force beyond ±F acts
as ±F.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.physics import kernels

FloatArray = NDArray[np.float64]

DT = 0.01
"""Sample time of the bench in s (the paper's 100 Hz): the one place it is written.

Configurations and models carry their own ``dt``; this is only their default."""


@dataclass(frozen=True)
class PlantParams:
    """Physical parameters of the NL-MSD (docs/design.md §Plant; field order = :class:`kernels.Plant`)."""

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
    dt: float = DT
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

    def kernel(self) -> kernels.Plant:
        """These parameters as the compiled step reads them."""
        return kernels.Plant(m=self.m, c=self.c, k=self.k, g=self.g, h=self.h, L=self.L, F=self.F,
                             dt=self.dt)

    def as_array(self) -> FloatArray:
        """Parameters packed for :class:`kernels.Kernel`: [m, c, k, g, h, L, F, dt]."""
        return np.array(self.kernel(), dtype=np.float64)


PRESETS: dict[str, PlantParams] = {
    "default": PlantParams(),
    # Nearly linear static map (stiffness 4.9-5.1 N/m over the reachable range):
    # shows when the piecewise model is not needed.
    "mild": PlantParams(k=5.0, h=0.7),
    # The rig emulator's own plant (launch_scripts/rig.py, docs/rig.md §Preset): each physical
    # parameter 12-20 % off the default, in mixed directions (heavier, less damped, softer spring,
    # harder cubic), so no single scale factor recovers it. The pipeline is never told these.
    "rig": PlantParams(m=1.15, c=0.85, k=2.1, h=1.2),
}


def preset(name: str, **overrides: float) -> PlantParams:
    """A named parameter set, optionally with fields overridden."""
    if name not in PRESETS:
        raise ConfigError(f"unknown plant preset {name!r}; choose one of {sorted(PRESETS)}")
    return replace(PRESETS[name], **overrides)


def check_force(u: float, params: PlantParams) -> float:
    """The force that acts: ``u`` saturated to ±F; a non-finite ``u`` raises InvalidInputError."""
    return float(kernels.saturate(float(u), params.F))


def spring_force(x: FloatArray | float, params: PlantParams) -> FloatArray | float:
    """Restoring force k sin(g x) + h x³ (N): the plant's static nonlinearity."""
    return params.k * np.sin(params.g * x) + params.h * np.power(x, 3)


def step(x: float, v: float, u: float, params: PlantParams) -> tuple[float, float]:
    """One Euler step from (x, v) under force u; returns the new (x, v).

    The force is saturated to ±F before it acts; a non-finite one raises
    :class:`InvalidInputError` (from the compiled step, like every other path).
    """
    x_new, v_new = kernels.plant_step(params.kernel(), float(x), float(v), float(u))
    return float(x_new), float(v_new)


def step_batch(
    x: FloatArray, v: FloatArray, u: FloatArray, params: PlantParams
) -> tuple[FloatArray, FloatArray]:
    """:func:`step` over any number of independent plants (element-wise equal to it)."""
    xs, vs, us = (np.ascontiguousarray(a, dtype=np.float64) for a in (x, v, u))
    if not (xs.ndim == 1 and xs.shape == vs.shape == us.shape):
        raise InvalidInputError(
            f"x, v and u must be 1-D arrays of one length, got {xs.shape}, {vs.shape}, {us.shape}")
    return kernels.plant_step_batch(params.kernel(), xs, vs, us)


def simulate(
    u: FloatArray, params: PlantParams, x0: float = 0.0, v0: float = 0.0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Drive the plant with the force sequence ``u``.

    Returns ``(x, v, u_applied)`` where ``x[k]`` is the position *before* the
    force ``u[k]`` acts (so ``x[0] = x0``), the sampling a recorder sees: the
    output at k and the command held over [k, k+1).
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    if u.ndim != 1 or u.size == 0:
        raise InvalidInputError("force sequence must be a non-empty 1-D array")
    x, v = kernels.simulate_plant(params.kernel(), u, float(x0), float(v0))
    return x, v, np.clip(u, -params.F, params.F)


def equilibrium(u: float, params: PlantParams) -> float:
    """Static position where the spring balances the constant force u (bisection)."""
    u = check_force(u, params)
    lo, hi = -params.x_max, params.x_max

    def f(x: float) -> float:
        return float(spring_force(x, params)) - u

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
