"""What the three baseline designs share: the operating point, the observer, the loop's plant side.

Why one module: every design starts from the same question — which force holds
the identified model at the set-point, and how does the model respond to small
deviations there — and the two model-based designs (LQR, MPC) see the plant
through the same observer. Keeping these here means a design module holds only
its own rule.

* :func:`operating_point` finds the equilibrium force of *any* model kind at a
  set-point and its linearisation there, numerically through the compiled
  ``kernels.advance_loaded`` (so the GLM gives its own coefficients back, the
  PLM its scheduled local model at the set-point, the grey-box its Jacobian).
* :class:`Observer` is a fixed-gain (steady-state Kalman) filter that runs the
  identified model itself as its predictor, with a force-bias state: the gain
  is designed with python-control's ``dlqe`` on the linearisation augmented
  with a constant input force, so an unknown load or a wrong equilibrium force
  leaves no bias in the estimate.
* :func:`plant_side` is the compiled loop's plant half, with exactly the
  semantics of :func:`msd_bench.core.closed_loop.greedy_under` (delay queue,
  load from ``load_step``, friction on the plant kind).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import control
import numba
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from msd_bench.core import kernels
from msd_bench.core.closed_loop import Conditions, _advance
from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.kernels import KIND_PLANT, Kernel
from msd_bench.core.model import StepModel
from msd_bench.core.qconfig import QConfig

FloatArray = NDArray[np.float64]

_FD_STEP = 1e-6
"""Central-difference step for the linearisation (m or N): the kernels are smooth there."""


def measured(y: float) -> float:
    """A measurement a stepwise controller accepts: finite, else a one-line error before any state moves."""
    value = float(y)
    if not math.isfinite(value):
        raise InvalidInputError(f"measured position must be finite, got {y!r}")
    return value


def alphabet(force: float) -> FloatArray:
    """The paper's five forces for a force limit ``force`` (the Q-learners' own alphabet)."""
    return QConfig(force=force).actions()


class OperatingPoint(NamedTuple):
    """A model linearised at an equilibrium: deviations ``z = s - s_eq`` obey ``z+ = A z + B du``."""

    target: float
    """Set-point, m."""
    u_eq: float
    """Force that holds the model at the set-point, N."""
    s_eq: FloatArray
    """The model's state slots at the equilibrium (``n`` of its four slots)."""
    a: FloatArray
    """State matrix (n, n) of the slots ``s[:n]``."""
    b: FloatArray
    """Input column (n,): the response of the slots to a force."""
    velocity: FloatArray
    """Row (n,) mapping slot deviations to velocity, m/s (plant: ``v``; ARX: ``(x_k - x_{k-1})/dt``)."""


def slots(model: StepModel) -> int:
    """How many state slots the kind uses: plant ``[x, v]``, ARX-type ``[x_k, x_{k-1}, u_{k-1}]``."""
    return 2 if model.kind == KIND_PLANT else 3


def _rest_state(model: StepModel, x: float, u: float) -> FloatArray:
    """The state of a model at rest at ``x`` under force ``u``."""
    return np.array([x, 0.0, 0.0, 0.0]) if model.kind == KIND_PLANT else np.array([x, x, u, 0.0])


def _next(model: StepModel, s: FloatArray, u: float, load: float) -> FloatArray:
    state = s.copy()
    kernels.advance_loaded(model.kernel, state, u, load)
    return state


def equilibrium_force(model: StepModel, target: float) -> float:
    """The force within ±F that holds ``model`` at rest at ``target`` (a root of its static map)."""
    def residual(u: float) -> float:
        return float(_next(model, _rest_state(model, target, u), u, 0.0)[0] - target)

    f = model.force_limit
    grid = np.linspace(-f, f, 41)
    values = [residual(float(u)) for u in grid]
    for lo, hi, vlo, vhi in zip(grid[:-1], grid[1:], values[:-1], values[1:], strict=True):
        if vlo == 0.0:
            return float(lo)
        if vlo * vhi < 0.0:
            return float(brentq(residual, lo, hi, xtol=1e-12))
    if values[-1] == 0.0:
        return float(f)
    raise ConfigError(f"model {model.name!r} cannot hold the set-point {target} m with a force within ±{f} N")


def operating_point(model: StepModel, target: float) -> OperatingPoint:
    """Equilibrium and Jacobians of ``model`` at ``target`` (central differences of the kernel)."""
    if not (math.isfinite(target) and abs(target) < model.x_max):
        raise ConfigError(f"set-point must be finite and inside the ±{model.x_max} m stroke, got {target}")
    u_eq = equilibrium_force(model, target)
    n = slots(model)
    s_eq = _rest_state(model, target, u_eq)
    a = np.empty((n, n))
    for i in range(n):
        up, down = s_eq.copy(), s_eq.copy()
        up[i] += _FD_STEP
        down[i] -= _FD_STEP
        a[:, i] = (_next(model, up, u_eq, 0.0) - _next(model, down, u_eq, 0.0))[:n] / (2 * _FD_STEP)
    # A load enters exactly like an unsaturated force and is never clipped, so it is the input column.
    b = (_next(model, s_eq, u_eq, _FD_STEP) - _next(model, s_eq, u_eq, -_FD_STEP))[:n] / (2 * _FD_STEP)
    velocity = np.zeros(n)
    if model.kind == KIND_PLANT:
        velocity[1] = 1.0
    else:
        velocity[0], velocity[1] = 1.0 / model.dt, -1.0 / model.dt
    return OperatingPoint(float(target), u_eq, s_eq[:n].copy(), a, b, velocity)


def transfer_function(op: OperatingPoint, dt: float) -> control.TransferFunction:
    """Force deviation to position deviation at the operating point, as a discrete transfer function."""
    n = op.b.size
    c = np.zeros((1, n))
    c[0, 0] = 1.0
    sys = control.ss(op.a, op.b.reshape(n, 1), c, np.zeros((1, 1)), dt)
    return control.minreal(control.ss2tf(sys), verbose=False)


class Observer(NamedTuple):
    """A fixed-gain filter on a model (compiled form): predict with the model, correct by the innovation."""

    model: Kernel
    """The model the predictor runs."""
    gain: FloatArray
    """Current-estimate gains on the innovation: one per used slot, then the force bias (N/m)."""
    n: int
    """Used slots of the model's state."""
    bias_limit: float
    """The bias estimate is held within ±bias_limit N (a larger load could not be held anyway)."""


class ObserverNoise(NamedTuple):
    """The noise the steady-state Kalman gain is designed for (tuning knobs, stated in docs/baselines.md)."""

    sensor: float = 1e-3
    """Measurement noise σ, m."""
    force: float = 0.5
    """Force noise σ on the input channel per sample, N (quantisation chatter and model error)."""
    bias: float = 0.02
    """Random-walk σ of the force bias per sample, N."""


def observer_gain(op: OperatingPoint, noise: ObserverNoise) -> FloatArray:
    """Steady-state Kalman gain (current-estimate form) of the linearisation augmented with a force bias.

    ``dlqe`` returns the predictor gain and the prediction covariance P; the
    measurement-update gain is ``P Cᵀ (C P Cᵀ + R)⁻¹``.
    """
    n = op.b.size
    a = np.zeros((n + 1, n + 1))
    a[:n, :n] = op.a
    a[:n, n] = op.b
    a[n, n] = 1.0
    g = np.zeros((n + 1, 2))
    g[:n, 0] = op.b
    g[n, 1] = 1.0
    c = np.zeros((1, n + 1))
    c[0, 0] = 1.0
    qn = np.diag([noise.force ** 2, noise.bias ** 2])
    rn = np.array([[noise.sensor ** 2]])
    _, p, _ = control.dlqe(a, g, c, qn, rn)
    m = p @ c.T / (c @ p @ c.T + rn)[0, 0]
    return np.ascontiguousarray(m[:, 0])


def observer_state() -> FloatArray:
    """A zeroed observer state: the model's four slots, then the force-bias estimate."""
    return np.zeros(5)


@numba.njit(cache=True)
def observe_first(ob: Observer, ost: FloatArray, y: float) -> None:
    """Start the estimate at rest at the first measurement, with no bias (as the Q-learners' observer)."""
    ost[:] = 0.0
    ost[0] = y
    if ob.model.kind != KIND_PLANT:
        ost[1] = y


@numba.njit(cache=True)
def observe(ob: Observer, ost: FloatArray, u: float, y: float) -> None:
    """Predict one sample under the commanded ``u`` plus the bias estimate, then correct toward ``y``."""
    pred = kernels.advance_loaded(ob.model, ost[:4], u, ost[4])
    r = y - pred
    for i in range(ob.n):
        ost[i] += ob.gain[i] * r
    b = ost[4] + ob.gain[ob.n] * r
    ost[4] = min(max(b, -ob.bias_limit), ob.bias_limit)


def make_observer(model: StepModel, op: OperatingPoint, noise: ObserverNoise) -> Observer:
    """The compiled observer of ``model`` with its gain designed at ``op``."""
    return Observer(model.kernel, observer_gain(op, noise), op.b.size, float(model.force_limit))


@numba.njit(cache=True)
def nearest(forces: FloatArray, u: float) -> float:
    """The alphabet force nearest ``u`` (ties to the lower one): the 5-force actuator."""
    best: float = forces[0]
    for f in forces:
        if abs(f - u) < abs(best - u):
            best = f
    return best


@numba.njit(cache=True)
def plant_side(plant: Kernel, state: FloatArray, queue: FloatArray, k: int, u: float,
               cond: Conditions) -> float:
    """Command ``u`` issued at sample ``k``; the plant advances under the one issued ``delay`` ago.

    Exactly :func:`closed_loop.greedy_under`'s plant half: a queue of
    ``delay + 1`` commands, a load from ``load_step`` on, friction on the plant kind.
    """
    queue[k % (cond.delay + 1)] = u
    applied = queue[(k + 1) % (cond.delay + 1)]
    load = cond.load if k >= cond.load_step else 0.0
    x: float = _advance(plant, state, applied, load, cond.friction)
    return x
