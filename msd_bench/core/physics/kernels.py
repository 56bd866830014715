"""Compiled one-step kernels shared by the plant, every surrogate and the learners.

Why one module: Q-learning runs ~10^6 sequential steps per agent, so the model
it learns on must be stepped in compiled code. Every plant-like model reaches
compiled code as one :class:`Kernel` — a kind, a flat float64 parameter array
and the force limit — and is advanced by :func:`advance`, which numba compiles
once. The same kernel serves the in-process trainer, the ROS nodes, the
Python-facing :mod:`msd_bench.core.physics.plant` and the tests, so a model behaves
identically wherever it runs. The plant's physics exists once, in
:func:`plant_step`.

Force policy, the same on every path: a non-finite force raises
:class:`InvalidInputError` here, inside the compiled step, before any state is
touched (so not even a direct kernel call can move the mass on a NaN); a
finite force beyond ``±force_limit`` acts exactly as the bound, for the plant
and for every surrogate (the surrogate stands in for a plant with that F). A
non-finite position (only reachable from a non-finite state) raises too,
rather than being parked somewhere.

State layout (float64[4], zeros = at rest at the origin):

* ``KIND_PLANT``: ``[x_k, v_k, 0, 0]``
* ARX-type models (linear, PLM, NLARX): ``[x_k, x_{k-1}, u_{k-1}, 0]``
* ``KIND_GREYBOX_RIG`` alone needs more (float64[:data:`RIG_STATE_SIZE`]):
  ``[x_k, v_k, f_k, u_{k-1}, ..., u_{k-D}]`` — position, velocity, the
  actuator lag's output at ``t_k`` and the saturated commands still in the
  delay line (newest first, ``D =`` :data:`RIG_DELAY_MAX` slots, of which the
  model's delay ``d`` are used). Why it grows: a delay of d samples behind a
  first-order lag is ``d + 1`` numbers of actuator memory, and d = 2 with a
  lag does not fit in four floats. Its kernel refuses a shorter state rather
  than read past it.

Every caller allocates and addresses a state through this module, never by a
literal: :func:`state_size` (a kind's length), :data:`STATE_MAX` (a buffer
for any kind), :func:`used_slots` (the leading slots that evolve),
:func:`holds_velocity` (slot :data:`MOTION` is ``v``, not ``x_{k-1}``) and
the slot names :data:`POS`, :data:`MOTION`, :data:`ARX_INPUT`, :data:`RIG_LAG`.

``advance(model, state, u_k)`` applies force ``u_k`` over one sample,
updates ``state`` in place and returns ``x_{k+1}``. Every model's output is
projected on the stroke ``[-L/2, L/2]`` like the plant's hard stops.

Parameter layouts (``Kernel.params``):

* plant: the fields of :class:`Plant` in order, ``[m, c, k, g, h, L, F, dt]``
* linear: ``[L, n1, n2, d1, d2, u0, y0]`` — deviation form
  ``(y-y0)[k+1] = n1 (u-u0)[k] + n2 (u-u0)[k-1] - d1 (y-y0)[k] - d2 (y-y0)[k-1]``
* PLM: ``[L, 5 x (n1, n2, d1, d2, u0, y0)]`` — five local linear models in
  deviation form around their operating points, all fed the shared blended
  history, blended by the paper's memberships f1..f5 of the current position;
  or ``[L, 5 x (n1, n2, d1, d2, u0, y0), c1..c5]`` (``PLM_SCHEDULED_SIZE``) —
  the same five models interpolated linearly between the two whose centres
  ``c1 < ... < c5`` (their identified operating positions) bracket the
  current position, the outer models alone beyond ``c1`` and ``c5``
* greybox-rig: the plant's ``[m, c, k, g, h, L, F, dt]`` then
  ``[friction, tau, delay]`` — Coulomb friction (N), the actuator lag's time
  constant (s, 0 = none) and the input delay (whole samples, at most
  :data:`RIG_DELAY_MAX`): the rig emulator's actuator and friction
  (:mod:`msd_bench.core.rigs.rig`) as a model, driven by the *commanded* force
* rk4 (:mod:`msd_bench.core.identification.greybox_rk4`): ``[m, c, k1, k2, k3, L, F, dt, ks, gs,
  fc, vc, f0, substeps, interp]`` — ``m x'' = f - c x' - k1 x - k2 x² - k3 x³ - ks sin(gs x)
  - fc tanh(x'/vc) + f0``, integrated by classical Runge-Kutta (RK4) with ``substeps`` equal
  substeps per sample; the force ``f`` is the saturated command held over the sample
  (``interp = 0``, a ZOH actuator) or ramped linearly from the previous sample's command to this
  one (``interp = 1``, a band-limited generator seen causally). Its state is ``[x, v, u_{k-1}, 0]``.
  L, F and dt sit where the plant's do, so code that reads a plant-like model's stroke and
  sample time reads them alike.
* held: ``[n, inner kind, inner parameters...]`` — the inner model stepped ``n`` times under one
  command (a decision held over ``n`` rig samples; its ``dt`` is the decision period); its state is
  the inner kind's (:func:`state_size` gives :data:`STATE_MAX`, which holds any)
* NLARX: ``[L, S, x_scale, u_scale, c0, w1, w2, w3, w4, S x (alpha, b1..b4, b0)]``
  with ``phi = [x_k/xs, x_{k-1}/xs, u_k/us, u_{k-1}/us]`` and
  ``x_{k+1} = xs (c0 + w.phi + sum_j alpha_j sigmoid(b_j.phi + b0_j))``.
  The paper form has ``w = 0``.

The kernels index these vectors without checks; every vector's length, count
rule (NLARX: ``S`` in slot 1) and bounds are stated once per kind in
:data:`msd_bench.core.identification.model_kinds.KERNEL_LAYOUTS`, which every
:class:`msd_bench.core.physics.model.StepModel` is checked against before a kernel
sees it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.kernel_cache import kernel

FloatArray = NDArray[np.float64]

KIND_PLANT = 0
KIND_LINEAR = 1
KIND_PLM = 2
KIND_NLARX = 3
KIND_GREYBOX_RIG = 4
KIND_RK4 = 5
KIND_HELD = 6

KIND_NAMES = {KIND_PLANT: "plant", KIND_LINEAR: "linear", KIND_PLM: "plm", KIND_NLARX: "nlarx",
              KIND_GREYBOX_RIG: "greybox-rig", KIND_RK4: "rk4", KIND_HELD: "held"}
HELD_HEAD = 2
"""A held model's parameters: ``[n, inner kind, inner parameters...]`` — the inner model stepped ``n``
times under one command per :func:`advance` (a decision held over ``n`` rig samples, issue 37 item 3)."""

PLM_CENTRES = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
"""Nominal centres of f1..f5 (f1 is 1 below -2, f5 is 1 above 1.5)."""

PLANT_SIZE = 8
LINEAR_SIZE = 7
PLM_LOCAL_SIZE = 6
PLM_SIZE = 1 + 5 * PLM_LOCAL_SIZE
PLM_SCHEDULED_SIZE = PLM_SIZE + 5
NLARX_HEAD = 9
NLARX_UNIT = 6
RIG_SIZE = PLANT_SIZE + 3
RK4_SIZE = 15
"""Parameters of an rk4 model (module docstring)."""
RK4_SUBSTEPS_MAX = 64
"""Most RK4 substeps per sample an rk4 model may state."""
RIG_DELAY_MAX = 5
"""Longest input delay (samples) a greybox-rig model may state: the delay line's slots."""
RIG_STATE_SIZE = 3 + RIG_DELAY_MAX
"""State length of a greybox-rig model (x, v, the lag's output, the delay line)."""
ARX_STATE_SIZE = 4
"""State length of the plant and the ARX-type kinds (``[x, v, 0, 0]`` or ``[x_k, x_{k-1}, u_{k-1}, 0]``)."""
STATE_MAX = max(RIG_STATE_SIZE, ARX_STATE_SIZE)
"""Longest state of any kind: a buffer this long holds any model's state (callers that mix kinds)."""
POS = 0
"""Slot of the position in every kind's state."""
MOTION = 1
"""Slot of the second state: the velocity (plant-structure kinds, :func:`holds_velocity`) or the
previous position (ARX-type kinds)."""
ARX_INPUT = 2
"""Slot of the last acting force ``u_{k-1}`` in an ARX-type state."""
RIG_LAG = 2
"""Slot of the actuator lag's output in a greybox-rig state; the delay line follows it."""


class Plant(NamedTuple):
    """The NL-MSD's parameters as compiled code reads them (units and ranges: ``PlantParams``).

    The field order is the plant's packed layout in :attr:`Kernel.params`.
    """

    m: float
    c: float
    k: float
    g: float
    h: float
    L: float
    F: float
    dt: float


class Kernel(NamedTuple):
    """A plant-like model as compiled code sees it."""

    kind: int
    """``KIND_*``: which step :func:`advance` runs."""
    params: FloatArray
    """Parameters in the kind's layout (module docstring), contiguous float64."""
    force_limit: float
    """Forces saturate to ±force_limit before they act (the plant's F, for every kind)."""


@kernel
def state_size(kind: int) -> int:
    """Length of a model state of kernel ``kind`` (module docstring): what a caller allocates.

    Why a function and not a literal: the greybox-rig's state carries its
    actuator and is longer than four floats; every caller that allocates or
    addresses a model state asks here, so a new kind changes one place.
    """
    if kind == KIND_GREYBOX_RIG:
        return RIG_STATE_SIZE
    if kind == KIND_HELD:  # any inner kind's state fits (its kernel uses its own leading slots)
        return STATE_MAX
    return ARX_STATE_SIZE


@kernel
def held_inner(model: Kernel) -> Kernel:
    """The model a held model steps (``params[HELD_HEAD:]`` under its inner kind)."""
    return Kernel(int(model.params[1]), model.params[HELD_HEAD:], model.force_limit)


@kernel
def base_kind(model: Kernel) -> int:
    """The kind whose state layout ``model``'s state has: a held model's inner kind, else its own."""
    return int(model.params[1]) if model.kind == KIND_HELD else model.kind


@kernel
def step_period(model: Kernel) -> float:
    """Seconds one :func:`advance` of a velocity-holding ``model`` spans: its plant's sample time, times
    ``n`` for a model held over ``n`` samples (one decision). Why: an observer converting a velocity to
    the displacement between two decisions must use the decision's span; a held model's own
    ``params`` lead with its head, not a plant's, so reading its sample time there reads garbage."""
    if model.kind == KIND_HELD:
        return float(plant_of(model.params[HELD_HEAD:]).dt * model.params[0])
    return plant_of(model.params).dt


@kernel
def holds_velocity(kind: int) -> bool:
    """Slot :data:`MOTION` is the velocity (plant, greybox-rig, rk4), not the previous position (ARX)."""
    return kind in (KIND_PLANT, KIND_GREYBOX_RIG, KIND_RK4)


@kernel
def used_slots(model: Kernel) -> int:
    """How many leading slots of ``model``'s state evolve: plant ``[x, v]``, ARX-type
    ``[x_k, x_{k-1}, u_{k-1}]``, greybox-rig ``[x, v, f]`` and the ``delay`` slots of its line; a held
    model its inner model's."""
    kind = base_kind(model)
    p = model.params[HELD_HEAD:] if model.kind == KIND_HELD else model.params  # a held one's is never held
    if kind == KIND_PLANT:
        return 2
    if kind == KIND_GREYBOX_RIG:
        return RIG_LAG + 1 + int(p[RIG_SIZE - 1])
    return ARX_INPUT + 1  # ARX-type [x_k, x_{k-1}, u_{k-1}] and rk4 [x, v, u_{k-1}]


@kernel
def plant_of(p: FloatArray) -> Plant:
    """The plant's packed parameters as a :class:`Plant` (the one place that knows the slots)."""
    return Plant(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7])


@kernel
def saturate(u: float, limit: float) -> float:
    """The force that acts: ``u`` clipped to ±limit; a non-finite ``u`` is refused."""
    if not math.isfinite(u):
        raise InvalidInputError("force must be finite")
    if u > limit:
        return limit
    if u < -limit:
        return -limit
    return u


@kernel
def on_stroke(x: float, half_stroke: float) -> float:
    """``x`` projected on [-half_stroke, half_stroke]; NaN (a non-finite state) is refused."""
    if x > half_stroke:
        return half_stroke
    if x < -half_stroke:
        return -half_stroke
    if x != x:
        raise InvalidInputError("model produced a non-finite position (was its state finite?)")
    return x


@kernel
def membership(i: int, x: float) -> float:
    """Triangular membership f_{i+1}(x) exactly as printed in the paper (eq. 13).

    The printed outer ramps are asymmetric (f1 ramps over [-2, -1] with slope 1,
    f5 over [1, 1.5] with slope 2); they are kept as printed.
    """
    if i == 0:
        if x < -2.0:
            return 1.0
        if x <= -1.0:
            return -(x + 1.0)
        return 0.0
    if i == 1:
        if x < -1.5:
            return 0.0
        if x <= -1.0:
            return 2.0 * (x + 1.5)
        if x <= -0.5:
            return -2.0 * (x + 0.5)
        return 0.0
    if i == 2:
        if x < -1.0:
            return 0.0
        if x <= 0.0:
            return x + 1.0
        if x <= 1.0:
            return -(x - 1.0)
        return 0.0
    if i == 3:
        if x < 0.5:
            return 0.0
        if x <= 1.0:
            return 2.0 * (x - 0.5)
        if x <= 1.5:
            return -2.0 * (x - 1.5)
        return 0.0
    if x < 1.0:
        return 0.0
    if x <= 1.5:
        return 2.0 * (x - 1.0)
    return 1.0


@kernel
def plant_step(plant: Plant, x: float, v: float, u: float) -> tuple[float, float]:
    """One Euler step of ``m x'' = u - c x' - k sin(g x) - h x^3`` from (x, v); the new (x, v).

    The force is saturated to ±F (non-finite: refused); velocity is updated
    first and the position moves with the new velocity; a position beyond a
    hard stop is projected on it and the velocity zeroed.
    """
    u = saturate(u, plant.F)
    # Operation order is part of the pinned results: dt * (net force) first, then / m.
    v_new = v + plant.dt * (u - plant.c * v - plant.k * math.sin(plant.g * x)
                            - plant.h * x * x * x) / plant.m
    x_free = x + plant.dt * v_new
    x_new = on_stroke(x_free, 0.5 * plant.L)
    if x_new != x_free:
        v_new = 0.0
    return x_new, v_new


@kernel
def plant_step_loaded(plant: Plant, x: float, v: float, u: float, load: float,
                      friction: float) -> tuple[float, float]:
    """:func:`plant_step` with an external ``load`` force (N, added after the actuator saturates)
    and Coulomb ``friction`` (N): what a rig adds to the ideal plant (scenarios, the rig emulator).

    With both zero it *is* :func:`plant_step`. Friction opposes motion with
    constant magnitude; at rest it holds the mass while the other forces stay
    within it, and it never reverses the velocity within a step (the mass stops).
    """
    if load == 0.0 and friction == 0.0:
        return plant_step(plant, x, v, u)
    drive = saturate(u, plant.F) + load
    spring = plant.k * math.sin(plant.g * x) + plant.h * x * x * x
    net = drive - plant.c * v - spring
    if friction > 0.0:
        if v != 0.0:
            net -= friction if v > 0.0 else -friction
        elif abs(net) <= friction:
            net = 0.0
        else:
            net -= friction if net > 0.0 else -friction
    v_new = v + plant.dt * net / plant.m
    if friction > 0.0 and v != 0.0 and v_new * v < 0.0:
        v_new = 0.0  # friction stops the mass; it cannot push it backwards
    x_free = x + plant.dt * v_new
    x_new = on_stroke(x_free, 0.5 * plant.L)
    if x_new != x_free:
        v_new = 0.0
    return x_new, v_new


@kernel
def plant_step_batch(plant: Plant, x: FloatArray, v: FloatArray,
                     u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`plant_step` of independent plants, element by element (equal to the scalar step)."""
    n = x.shape[0]
    x_new = np.empty(n)
    v_new = np.empty(n)
    for i in range(n):
        x_new[i], v_new[i] = plant_step(plant, x[i], v[i], u[i])
    return x_new, v_new


@kernel
def _local(p: FloatArray, o: int, s: FloatArray, u: float) -> float:
    """Local linear model at offset ``o`` of ``p`` in deviation form (linear and PLM kinds)."""
    n1, n2, d1, d2, u0, y0 = p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5]
    y: float = y0 + n1 * (u - u0) + n2 * (s[2] - u0) - d1 * (s[0] - y0) - d2 * (s[1] - y0)
    return y


@kernel
def _plm_scheduled(p: FloatArray, s: FloatArray, u: float) -> float:
    """Linear interpolation between the two local models whose centres bracket the position.

    The centres ``p[PLM_SIZE:PLM_SIZE + 5]`` (increasing) are where each local
    model was identified; the weights are hat functions on them (a partition of
    unity), constant beyond the outer centres.
    """
    xi = s[0]
    o = PLM_SIZE
    if xi <= p[o]:
        return _local(p, 1, s, u)
    if xi >= p[o + 4]:
        return _local(p, 1 + PLM_LOCAL_SIZE * 4, s, u)
    j = 0
    while j < 3 and xi >= p[o + j + 1]:
        j += 1
    t = (xi - p[o + j]) / (p[o + j + 1] - p[o + j])
    lo = _local(p, 1 + PLM_LOCAL_SIZE * j, s, u)
    hi = _local(p, 1 + PLM_LOCAL_SIZE * (j + 1), s, u)
    y: float = (1.0 - t) * lo + t * hi
    return y


@kernel
def _plm(p: FloatArray, s: FloatArray, u: float) -> float:
    """Membership-weighted blend of the five local models at the current position."""
    if p.shape[0] == PLM_SCHEDULED_SIZE:
        return _plm_scheduled(p, s, u)
    xi = s[0]
    num = 0.0
    den = 0.0
    for i in range(5):
        w = membership(i, xi)
        if w > 0.0:
            num += w * _local(p, 1 + PLM_LOCAL_SIZE * i, s, u)
            den += w
    if den <= 0.0:  # cannot happen with f1..f5 as printed; nearest centre as a guard
        best = 0
        for i in range(5):
            if abs(xi - PLM_CENTRES[i]) < abs(xi - PLM_CENTRES[best]):
                best = i
        return _local(p, 1 + PLM_LOCAL_SIZE * best, s, u)
    return num / den


@kernel
def _nlarx(p: FloatArray, s: FloatArray, u: float) -> float:
    """Linear term plus sigmoid units on the scaled regressors (layout in the module doc)."""
    n_units = int(p[1])
    xs, us = p[2], p[3]
    c0, w1, w2, w3, w4 = p[4], p[5], p[6], p[7], p[8]
    f0, f1, f2, f3 = s[0] / xs, s[1] / xs, u / us, s[2] / us
    out = c0 + w1 * f0 + w2 * f1 + w3 * f2 + w4 * f3
    for j in range(n_units):
        o = NLARX_HEAD + NLARX_UNIT * j
        alpha, b1, b2, b3, b4, b0 = p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5]
        z = b1 * f0 + b2 * f1 + b3 * f2 + b4 * f3 + b0
        out += alpha / (1.0 + math.exp(-z))
    y: float = xs * out
    return y


@kernel
def advance(model: Kernel, s: FloatArray, u: float) -> float:
    """Apply force ``u`` for one sample; update ``s`` in place; return the new position.

    ``u`` is saturated to ±``model.force_limit`` (a non-finite one raises before
    ``s`` changes); an unknown kind raises rather than running another kind's maths.
    A held model (:data:`KIND_HELD`) steps its inner model ``n`` times under ``u``: one
    decision held over ``n`` samples. Every other kind runs exactly :func:`_advance_one`.
    """
    if model.kind == KIND_HELD:
        inner = held_inner(model)
        x = float(s[0])
        for _ in range(int(model.params[0])):
            x = _advance_one(inner, s, u)
        return x
    return _advance_one(model, s, u)


@kernel
def _advance_one(model: Kernel, s: FloatArray, u: float) -> float:
    """:func:`advance` of every kind but a held one."""
    u = saturate(u, model.force_limit)
    if model.kind == KIND_PLANT:
        x, v = plant_step(plant_of(model.params), s[0], s[1], u)
        s[0] = x
        s[1] = v
        return x
    if model.kind == KIND_GREYBOX_RIG:
        return _rig_step(model.params, s, u, 0.0)
    if model.kind == KIND_RK4:
        return rk4_advance(model.params, s, u, 0.0)
    return _arx_step(model, s, u)


@kernel
def advance_loaded(model: Kernel, s: FloatArray, u: float, load: float) -> float:
    """:func:`advance` with an external ``load`` force (N) added after the actuator saturates.

    A load is outside the actuator, so it is not clipped to ±F. A plant-kind
    model takes it into its force balance (:func:`plant_step_loaded`); an
    ARX-type model takes it on its input (the total force is what its
    regressors see, so its input memory holds the sum). Beyond ±F an ARX
    model extrapolates: it was identified on saturated commands only. A held model
    steps its inner model ``n`` times under ``u`` and the load.
    """
    if model.kind == KIND_HELD:
        inner = held_inner(model)
        x = float(s[0])
        for _ in range(int(model.params[0])):
            x = _advance_loaded_one(inner, s, u, load)
        return x
    return _advance_loaded_one(model, s, u, load)


@kernel
def _advance_loaded_one(model: Kernel, s: FloatArray, u: float, load: float) -> float:
    """:func:`advance_loaded` of every kind but a held one."""
    if model.kind == KIND_PLANT:
        x, v = plant_step_loaded(plant_of(model.params), s[0], s[1], u, load, 0.0)
        s[0] = x
        s[1] = v
        return x
    if model.kind == KIND_GREYBOX_RIG:
        return _rig_step(model.params, s, saturate(u, model.force_limit), load)
    if model.kind == KIND_RK4:
        return rk4_advance(model.params, s, saturate(u, model.force_limit), load)
    return _arx_step(model, s, saturate(u, model.force_limit) + load)


@kernel
def rig_actuator(p: FloatArray, s: FloatArray, u: float) -> float:
    """The greybox-rig actuator: queue the saturated command ``u``; the force acting over this sample.

    Exactly :class:`msd_bench.core.rigs.rig.Actuator` (dead time of ``p[10]``
    samples, then a first-order lag of time constant ``p[9]`` whose output is
    averaged over the sample), on the state slots ``s[2:]`` (module docstring),
    so a model with the rig's values reproduces the rig's applied force.
    """
    tau = p[9]
    if tau <= 0.0:
        return _rig_actuator_lagged(p, s, u, 0.0, 0.0)
    decay = math.exp(-p[7] / tau)
    return _rig_actuator_lagged(p, s, u, decay, (tau / p[7]) * (1.0 - decay))


@kernel
def _rig_actuator_lagged(p: FloatArray, s: FloatArray, u: float, decay: float, gain: float) -> float:
    """:func:`rig_actuator` with the lag's per-sample ``decay = exp(-dt/tau)`` and ``gain =
    (tau/dt)(1 - decay)`` given (no lag when ``p[9] <= 0``): a rollout computes them once, not per
    sample (the same numbers, so the same result bit for bit)."""
    delay = int(p[10])
    if s.shape[0] < 3 + delay:
        raise InvalidInputError("greybox-rig model state is too short for its delay line")
    if delay == 0:
        target = u
    else:
        target = s[2 + delay]
        for j in range(delay - 1, 0, -1):
            s[3 + j] = s[2 + j]
        s[3] = u
    if p[9] <= 0.0:
        s[2] = target
        return target
    start = s[2]
    s[2] = target + (start - target) * decay
    force: float = target + (start - target) * gain
    return force


@kernel
def _rig_step(p: FloatArray, s: FloatArray, u: float, load: float) -> float:
    """One greybox-rig step: the actuator, then the rig's frictional plant (:func:`plant_step_loaded`)."""
    force = rig_actuator(p, s, u)
    x, v = plant_step_loaded(plant_of(p), s[0], s[1], force, load, p[8])
    s[0] = x
    s[1] = v
    return x


@kernel
def rk4_accel(p: FloatArray, x: float, v: float, f: float) -> float:
    """The rk4 model's acceleration at (x, v) under the acting force ``f`` (layout: module docstring)."""
    restoring = p[2] * x + p[3] * x * x + p[4] * x * x * x + p[8] * math.sin(p[9] * x)
    friction = p[1] * v + p[10] * math.tanh(v / p[11])
    a: float = (f + p[12] - restoring - friction) / p[0]
    return a


@kernel
def rk4_motion(p: FloatArray, x: float, v: float, f0: float, f1: float) -> tuple[float, float]:
    """(x, v) one sample on, by ``p[13]`` RK4 substeps under a force ramping from ``f0`` to ``f1``.

    No stroke and no check here: :func:`rk4_advance` projects and refuses a
    non-finite position, the fitter's simulation stops at one (a rejected step).
    """
    n = int(p[13])
    h = p[7] / n
    for i in range(n):
        fa = f0 + (f1 - f0) * (i / n)
        fm = f0 + (f1 - f0) * ((i + 0.5) / n)
        fb = f0 + (f1 - f0) * ((i + 1.0) / n)
        a1 = rk4_accel(p, x, v, fa)
        x2, v2 = x + 0.5 * h * v, v + 0.5 * h * a1
        a2 = rk4_accel(p, x2, v2, fm)
        x3, v3 = x + 0.5 * h * v2, v + 0.5 * h * a2
        a3 = rk4_accel(p, x3, v3, fm)
        x4, v4 = x + h * v3, v + h * a3
        a4 = rk4_accel(p, x4, v4, fb)
        x = x + h * (v + 2.0 * v2 + 2.0 * v3 + v4) / 6.0
        v = v + h * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0
    return x, v


@kernel
def rk4_advance(p: FloatArray, s: FloatArray, u: float, load: float) -> float:
    """One rk4-model sample under the saturated command ``u`` (and an external ``load``, held).

    The command ramps from the previous one (slot :data:`ARX_INPUT`) when ``p[14] = 1``;
    a position past the stroke is projected on it and the velocity zeroed, like the plant's stops.
    """
    start = s[ARX_INPUT] if p[14] > 0.5 else u
    x, v = rk4_motion(p, s[0], s[1], start + load, u + load)
    x_new = on_stroke(x, 0.5 * p[5])
    if x_new != x:
        v = 0.0
    s[0] = x_new
    s[1] = v
    s[ARX_INPUT] = u
    return x_new


@kernel
def rk4_simulate(p: FloatArray, u: FloatArray, x0: float, v0: float, u_prev: float) -> FloatArray:
    """Free run of an rk4 model without stroke (the fitter's): ``x[k]`` before ``u[k]`` acts.

    ``u`` is taken as the acting force (the caller saturates it). A non-finite
    state fills the rest with NaN: the fitter rejects that step.
    """
    n = u.shape[0]
    out = np.full(n, np.nan)
    x, v, last = x0, v0, u_prev
    ramp = p[14] > 0.5
    for k in range(n):
        out[k] = x
        x, v = rk4_motion(p, x, v, last if ramp else u[k], u[k])
        last = u[k]
        if not (math.isfinite(x) and math.isfinite(v)):
            break
    return out


@kernel
def _arx_step(model: Kernel, s: FloatArray, u: float) -> float:
    """One step of an ARX-type model (linear, PLM, NLARX) under the acting force ``u``."""
    kind, p = model.kind, model.params
    if kind == KIND_LINEAR:
        y = _local(p, 1, s, u)
    elif kind == KIND_PLM:
        y = _plm(p, s, u)
    elif kind == KIND_NLARX:
        y = _nlarx(p, s, u)
    else:
        raise InvalidInputError("unknown model kind")
    y = on_stroke(y, 0.5 * p[0])
    s[1] = s[0]
    s[0] = y
    s[2] = u
    return y


@kernel
def rollout(model: Kernel, u: FloatArray, state: FloatArray) -> FloatArray:
    """Free-run simulation: ``x[k]`` is the position before ``u[k]`` acts (``x[0]`` = state)."""
    if model.kind == KIND_GREYBOX_RIG:
        return _rig_rollout(model, u, state)
    n = u.shape[0]
    x = np.empty(n)
    for k in range(n):
        x[k] = state[0]
        advance(model, state, u[k])
    return x


@kernel
def _rig_rollout(model: Kernel, u: FloatArray, state: FloatArray) -> FloatArray:
    """:func:`rollout` of a greybox-rig model: each step is :func:`advance`'s, bit for bit.

    Why its own loop: the fit runs about 1,700 rollouts of a 12,000-sample record (most of the
    greybox-rig's identification time), and the step is a chain of dependent operations. Here the
    lag's constants are computed once, and the position, velocity and actuator output stay in
    registers instead of going through the state array every sample (only the delay line does);
    the arithmetic is the same, in the same order (tests/core/test_kernels_rig.py).
    """
    p = model.params
    tau = p[9]
    decay = math.exp(-p[7] / tau) if tau > 0.0 else 0.0
    gain = (tau / p[7]) * (1.0 - decay) if tau > 0.0 else 0.0
    delay = int(p[10])
    if state.shape[0] < 3 + delay:
        raise InvalidInputError("greybox-rig model state is too short for its delay line")
    plant = plant_of(p)
    friction = p[8]
    n = u.shape[0]
    out = np.empty(n)
    xk, vk, act = state[0], state[1], state[2]
    for k in range(n):
        out[k] = xk
        command = saturate(u[k], model.force_limit)
        if delay == 0:
            target = command
        else:
            target = state[2 + delay]
            for j in range(delay - 1, 0, -1):
                state[3 + j] = state[2 + j]
            state[3] = command
        if tau <= 0.0:
            act = target
            force = target
        else:
            start = act
            act = target + (start - target) * decay
            force = target + (start - target) * gain
        xk, vk = plant_step_loaded(plant, xk, vk, force, 0.0, friction)
    state[0], state[1], state[2] = xk, vk, act
    return out


@kernel
def simulate_plant(plant: Plant, u: FloatArray, x0: float,
                   v0: float) -> tuple[FloatArray, FloatArray]:
    """Plant trajectory (x, v) sampled before each force acts."""
    n = u.shape[0]
    x = np.empty(n)
    v = np.empty(n)
    xk, vk = x0, v0
    for k in range(n):
        x[k] = xk
        v[k] = vk
        xk, vk = plant_step(plant, xk, vk, u[k])
    return x, v


@kernel
def one_step(model: Kernel, x: FloatArray, u: FloatArray) -> FloatArray:
    """One-step-ahead prediction from measured history (ARX-type kinds only).

    ``yhat[k]`` predicts ``x[k]`` from ``x[k-1], x[k-2], u[k-1], u[k-2]``;
    the first two samples are copied from the measurement.
    """
    n = x.shape[0]
    yhat = x.copy()
    s = np.zeros(4)
    for k in range(2, n):
        s[0] = x[k - 1]
        s[1] = x[k - 2]
        s[2] = u[k - 2]
        yhat[k] = advance(model, s, u[k - 1])
    return yhat


@kernel
def rig_one_step(model: Kernel, y: FloatArray, u: FloatArray) -> FloatArray:
    """One-step-ahead prediction of a greybox-rig model from measured positions and commands.

    The actuator's memory needs no measurement (it is a function of the
    commands alone, from idle before sample 0), so it runs along the record;
    the plant's (x, v) at k-1 are the measured position and the backward
    difference, as the plain grey-box's one-step predictor takes them.
    ``yhat[:2] = y[:2]``.
    """
    p = model.params
    n = y.shape[0]
    yhat = y.copy()
    s = np.zeros(RIG_STATE_SIZE)
    plant = plant_of(p)
    for k in range(n - 1):
        force = rig_actuator(p, s, saturate(u[k], model.force_limit))
        if k >= 1:
            x, _ = plant_step_loaded(plant, y[k], (y[k] - y[k - 1]) / p[7], force, 0.0, p[8])
            yhat[k + 1] = x
    return yhat


@kernel
def rig_forces(model: Kernel, u: FloatArray) -> FloatArray:
    """The force a greybox-rig model's actuator applies per sample for commands ``u``, from idle."""
    s = np.zeros(RIG_STATE_SIZE)
    out = np.empty(u.shape[0])
    for k in range(u.shape[0]):
        out[k] = rig_actuator(model.params, s, saturate(u[k], model.force_limit))
    return out
