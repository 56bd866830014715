"""What the three baseline designs share: the operating point, the observer, the alphabet.

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

The closed loop itself is not here: each design registers its decision with
:func:`msd_bench.core.evaluation.closed_loop.decision` and runs in the one loop.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import control
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import KIND_GREYBOX_RIG, MOTION, POS, Kernel
from msd_bench.core.physics.model import StepModel

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
    """The model's used state slots at the equilibrium (``n`` = :func:`kernels.used_slots`)."""
    a: FloatArray
    """State matrix (n, n) of the slots ``s[:n]``."""
    b: FloatArray
    """Input column (n,): the response of the slots to the commanded force."""
    velocity: FloatArray
    """Row (n,) mapping slot deviations to velocity, m/s (plant: ``v``; ARX: ``(x_k - x_{k-1})/dt``)."""
    load: FloatArray
    """Load column (n,): the response of the slots to a force acting beside the actuator (the
    observer's bias enters here). The same as ``b`` except behind a greybox-rig's delay and lag."""


def _layout(model: StepModel) -> tuple[int, float]:
    """The kind whose state layout ``model`` steps and the seconds between its consecutive states:
    a held model's inner kind and sample time (its own ``dt`` is the decision's), else its own.

    Why: a baseline deciding every few rig samples is designed on the surrogate held over them; its
    state is the inner model's, and an ARX-type state's last two positions are one *sample* apart.
    """
    held = model.kind == kernels.KIND_HELD
    return int(kernels.base_kind(model.kernel)), model.dt / float(model.params[0]) if held else model.dt


def slots(model: StepModel) -> int:
    """How many state slots the kind uses (:func:`kernels.used_slots`)."""
    return int(kernels.used_slots(model.kernel))


def _rest_state(model: StepModel, x: float, u: float) -> FloatArray:
    """The full state of a model at rest at ``x`` under force ``u`` (every kind's layout)."""
    s = model.initial_state()
    s[POS] = x
    kind = _layout(model)[0]
    if not kernels.holds_velocity(kind):  # ARX: x_{k-1} = x, u_{k-1} = u
        s[MOTION] = x
        s[kernels.ARX_INPUT] = u
    elif kind == KIND_GREYBOX_RIG:  # the lag's output and every queued command are u
        s[kernels.RIG_LAG:slots(model)] = u
    elif kind == kernels.KIND_RK4:  # the ramp's start: the command that held it there
        s[kernels.ARX_INPUT] = u
    return s


def _smooth(model: StepModel) -> StepModel:
    """``model`` without Coulomb friction: the part a linear design can see.

    Why: friction holds a rig at rest over a band of forces, so the
    equilibrium force and the Jacobian at v = 0 are not defined with it; the
    designs are linear and meet friction as a disturbance, as a load.
    """
    if _layout(model)[0] != KIND_GREYBOX_RIG:
        return model
    p = model.params.copy()
    p[kernels.PLANT_SIZE + (kernels.HELD_HEAD if model.kind == kernels.KIND_HELD else 0)] = 0.0
    return StepModel(model.kind, p, model.name, dict(model.info), model.dt, model.force_limit)


def _next(model: StepModel, s: FloatArray, u: float, load: float) -> FloatArray:
    state = s.copy()
    kernels.advance_loaded(model.kernel, state, u, load)
    return state


def equilibrium_force(model: StepModel, target: float) -> float:
    """The force within ±F that holds ``model`` at rest at ``target`` (a root of its static map)."""
    def residual(u: float) -> float:
        return float(_next(model, _rest_state(model, target, u), u, 0.0)[POS] - target)

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
    model = _smooth(model)
    u_eq = equilibrium_force(model, target)
    n = slots(model)
    s_eq = _rest_state(model, target, u_eq)
    a = np.empty((n, n))
    for i in range(n):
        up, down = s_eq.copy(), s_eq.copy()
        up[i] += _FD_STEP
        down[i] -= _FD_STEP
        a[:, i] = (_next(model, up, u_eq, 0.0) - _next(model, down, u_eq, 0.0))[:n] / (2 * _FD_STEP)
    # A load is never clipped; it enters like an unsaturated force except behind an actuator.
    load = (_next(model, s_eq, u_eq, _FD_STEP) - _next(model, s_eq, u_eq, -_FD_STEP))[:n] / (2 * _FD_STEP)
    kind, sample = _layout(model)
    behind = kind in (KIND_GREYBOX_RIG, kernels.KIND_RK4)  # a delay line, a lag or a ramp
    b = _command_column(model, s_eq, u_eq, n) if behind else load
    velocity = np.zeros(n)
    if kernels.holds_velocity(kind):
        velocity[MOTION] = 1.0
    else:
        velocity[POS], velocity[MOTION] = 1.0 / sample, -1.0 / sample
    return OperatingPoint(float(target), u_eq, s_eq[:n].copy(), a, b, velocity, load)


def _command_column(model: StepModel, s_eq: FloatArray, u_eq: float, n: int) -> FloatArray:
    """Response of the used slots to the command (into the delay line, the lag or rk4's ramp),
    central differences.

    A one-sided difference at a saturated equilibrium force: the command cannot go beyond ±F.
    """
    hi = min(u_eq + _FD_STEP, model.force_limit)
    lo = max(u_eq - _FD_STEP, -model.force_limit)
    return np.asarray((_next(model, s_eq, hi, 0.0) - _next(model, s_eq, lo, 0.0))[:n] / (hi - lo))


def transfer_function(op: OperatingPoint, dt: float) -> control.TransferFunction:
    """Force deviation to position deviation at the operating point, as a discrete transfer function."""
    n = op.b.size
    c = np.zeros((1, n))
    c[0, POS] = 1.0
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
    size: int
    """Length of the model's state (:func:`kernels.state_size`); the force bias sits in slot ``size``."""
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
    a[:n, n] = op.load
    a[n, n] = 1.0
    g = np.zeros((n + 1, 2))
    g[:n, 0] = op.load
    g[n, 1] = 1.0
    c = np.zeros((1, n + 1))
    c[0, POS] = 1.0
    qn = np.diag([noise.force ** 2, noise.bias ** 2])
    rn = np.array([[noise.sensor ** 2]])
    _, p, _ = control.dlqe(a, g, c, qn, rn)
    m = p @ c.T / (c @ p @ c.T + rn)[0, 0]
    return np.ascontiguousarray(m[:, 0])


@kernel
def observer_state(ob: Observer) -> FloatArray:
    """A zeroed observer state: the model's state (its own length), then the force-bias estimate."""
    return np.zeros(ob.size + 1)


@kernel
def model_state(ob: Observer, ost: FloatArray) -> FloatArray:
    """The model's state inside the observer's (a view: the predictor advances it in place)."""
    return ost[:ob.size]


@kernel
def observe_first(ob: Observer, ost: FloatArray, y: float) -> None:
    """Start the estimate at rest at the first measurement, with no bias (as the Q-learners' observer)."""
    ost[:] = 0.0
    ost[POS] = y
    if not kernels.holds_velocity(ob.model.kind):
        ost[MOTION] = y


@kernel
def observe(ob: Observer, ost: FloatArray, u: float, y: float) -> None:
    """Predict one sample under the commanded ``u`` plus the bias estimate, then correct toward ``y``."""
    pred = kernels.advance_loaded(ob.model, model_state(ob, ost), u, ost[ob.size])
    r = y - pred
    for i in range(ob.n):
        ost[i] += ob.gain[i] * r
    b = ost[ob.size] + ob.gain[ob.n] * r
    ost[ob.size] = min(max(b, -ob.bias_limit), ob.bias_limit)


def make_observer(model: StepModel, op: OperatingPoint, noise: ObserverNoise) -> Observer:
    """The compiled observer of ``model`` with its gain designed at ``op``."""
    return Observer(model.kernel, observer_gain(op, noise), op.b.size, model.initial_state().size,
                    float(model.force_limit))


@kernel
def nearest(forces: FloatArray, u: float) -> float:
    """The alphabet force nearest ``u`` (ties to the lower one): the 5-force actuator."""
    best: float = forces[0]
    for f in forces:
        if abs(f - u) < abs(best - u):
            best = f
    return best
