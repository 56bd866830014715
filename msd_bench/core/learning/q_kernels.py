"""Compiled kernels of tabular Q-learning (paper §4), shared with Dyna-Q.

Why compiled: one paper-sized run is 900,000 strictly sequential steps, each a
model step, a state encoding, an ε-greedy choice and a TD update; plain Python
manages 0.05–0.25 M steps/s (benchmarks/bench_training.py). Every function
here is a :func:`~msd_bench.core.kernel_cache.kernel` (numba, cached), reads the
learner's settings by name from the :class:`~msd_bench.core.learning.qconfig.Learner` of
:func:`msd_bench.core.learning.qconfig.packed`, and steps the model (a
:class:`~msd_bench.core.physics.kernels.Kernel`) through
:func:`msd_bench.core.physics.kernels.advance`, so the learner trains on any plant-like
model. The Python-facing API is in :mod:`msd_bench.core.learning.qtrain`.

Conventions: ``x[k]`` is the position before action ``k`` acts; the reward of
step k is computed from ``E_{k+1} = |e_{k+1}|`` and ``E_k`` (the *unclipped* error:
the clip to ±e_max applies to the state index only); the last step of an
episode bootstraps (a time limit, not a terminal state); each agent ``i`` draws
all its randomness (targets, exploration, ties) from its own stream ``rng[i]``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.kernel_cache import kernel
from msd_bench.core.learning import rng
from msd_bench.core.learning.qconfig import MODE_PAPER, N_ACTIONS, OBS_ALPHA_BETA, OBS_NONE, Encoding, Learner
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.rigs.rig import actuate

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@kernel
def paper_bin(n_states: int, emax: float, e: float) -> int:
    """The paper's state (eq. 18): bin of ``e`` clipped to ±emax on a uniform grid of ``n_states``."""
    ec = min(max(e, -emax), emax)
    return math.floor((n_states - 1) * (ec + emax) / (2.0 * emax) + 0.5)


@kernel
def encode(enc: Encoding, e: float, dx: float, target: float) -> int:
    """State index of error ``e`` (paper), or of (lead error, sign of ``dx``, target bin) (improved)."""
    if enc.mode == MODE_PAPER:
        return paper_bin(enc.n_states, enc.e_max, e)
    eb = np.searchsorted(enc.err_edges, e + enc.lead_steps * dx, side="right")
    db = 0
    if enc.n_directions > 1:
        db = 1
        if dx < -enc.direction_tol:
            db = 0
        elif dx > enc.direction_tol:
            db = 2
    rb = np.searchsorted(enc.ref_edges, target, side="right")
    return int((eb * enc.n_directions + db) * (enc.ref_edges.size + 1) + rb)


@kernel
def reward(lr: Learner, err: float, err_prev: float) -> float:
    """``g / (1 + E_k) - ζ (E_k - E_{k-1}) / E_max`` with ``E = |e|`` (paper eq. 19).

    E in the closeness term is in paper metres (E / ``length_unit``, exactly E on the paper's plant),
    so a rig of another stroke is rewarded for the same fraction of it (docs/decisions.md §Scales).
    """
    return lr.g / (1.0 + err / lr.length_unit) - lr.zeta * (err - err_prev) / lr.e_max


@kernel
def choose(q: FloatArray, s: int, eps: float, state: rng.U64Array, i: int) -> int:
    """ε-greedy action; ties among equal maxima are broken uniformly at random."""
    a, state[i] = pick(q, s, eps, state[i])
    return a


@kernel(inline="always")
def pick(q: FloatArray, s: int, eps: float, z: np.uint64) -> tuple[int, np.uint64]:
    """:func:`choose` on a stream word held in a local: (action, the advanced word).

    One uniform decides explore or exploit; exploring draws the action, and
    exploiting draws only when several actions tie for the maximum.
    """
    # The row is read into a tuple first, so q is not live across any branch: numba can then drop
    # its reference count pair, in this function and where it is inlined (N_ACTIONS is 5).
    row = (q[s, 0], q[s, 1], q[s, 2], q[s, 3], q[s, 4])
    z, bits = rng.split(z)
    if rng.uniform_of(bits) < eps:
        z, bits = rng.split(z)
        return rng.below_of(rng.uniform_of(bits), N_ACTIONS), z
    best = row[0]
    count = 1
    for a in range(1, N_ACTIONS):
        v = row[a]
        if v > best:
            best = v
            count = 1
        elif v == best:
            count += 1
    k = 0
    if count > 1:
        z, bits = rng.split(z)
        k = rng.below_of(rng.uniform_of(bits), count)
    for a in range(N_ACTIONS):
        if row[a] == best:
            if k == 0:
                return a, z
            k -= 1
    return 0, z  # unreachable: best is one of the row's values


@kernel
def greedy(q: FloatArray, s: int) -> int:
    """Deterministic greedy action: the lowest index among equal maxima (like np.argmax)."""
    best = 0
    for a in range(1, N_ACTIONS):
        if q[s, a] > q[s, best]:
            best = a
    return best


@kernel
def td_update(q: FloatArray, s: int, a: int, r: float, s2: int, lr: Learner) -> None:
    """``Q[s,a] += α(A r + γ max Q[s'] − Q[s,a]) − η φ(s,a)`` (shaping as a penalty)."""
    q_update(q, s, a, r, s2, lr.alpha, lr.gamma, lr.reward_gain, lr.eta * lr.phi[s, a])


@kernel
def q_update(q: FloatArray, s: int, a: int, r: float, s2: int, alpha: float, gamma: float,
             gain: float, shaping: float) -> None:
    """:func:`td_update` with its weights spelled out; ``shaping`` is η φ(s, a)."""
    nxt = q[s2, 0]
    for b in range(1, N_ACTIONS):
        nxt = max(nxt, q[s2, b])
    td = gain * r + gamma * nxt - q[s, a]
    q[s, a] += alpha * td - shaping


@kernel
def draw_target(lr: Learner, state: rng.U64Array, i: int) -> float:
    """Episode target, uniform in [target_low, target_high]."""
    return lr.target_low + (lr.target_high - lr.target_low) * rng.uniform(state, i)


@kernel
def transition(model: Kernel, lr: Learner, q: FloatArray, plant: FloatArray, s: int, x: float,
               err: float, target: float, state: rng.U64Array,
               i: int) -> tuple[int, float, float, int, float]:
    """One learning step from state ``s`` at ``x``: act ε-greedily, advance, score, update Q.

    ``plant`` is the model's state (advanced in place). Returns
    ``(a, x_new, |e_new|, s_new, r)``. Shared by Q-learning and Dyna-Q so both
    take exactly the same step.
    """
    a = choose(q, s, lr.epsilon, state, i)
    x_new = kernels.advance(model, plant, lr.actions[a])
    e_new = x_new - target
    s2 = encode(lr.enc, e_new, x_new - x, target)
    r = reward(lr, abs(e_new), err)
    td_update(q, s, a, r, s2, lr)
    return a, x_new, abs(e_new), s2, r


class Memory(NamedTuple):
    """Dyna-Q's tabular model: the last (r, s') of every visited (s, a) pair ``j = s·5 + a``."""

    reward: FloatArray
    """Last reward seen after pair j."""
    next_state: IntArray
    """Last next state seen after pair j."""
    seen: BoolArray
    """Whether pair j was ever visited."""
    visited: IntArray
    """The visited pairs in order of first visit; the first ``n_visited[0]`` entries are valid."""
    n_visited: IntArray
    """One element: how many pairs were visited."""


@kernel
def new_memory(n_pairs: int) -> Memory:
    """An empty Dyna-Q memory for ``n_pairs`` state-action pairs (0 for plain Q-learning)."""
    return Memory(np.zeros(n_pairs), np.zeros(n_pairs, dtype=np.int64),
                  np.zeros(n_pairs, dtype=np.bool_), np.zeros(n_pairs, dtype=np.int64),
                  np.zeros(1, dtype=np.int64))


@kernel
def remember(mem: Memory, j: int, r: float, s2: int) -> None:
    """Store the outcome (r, s') of pair ``j``."""
    if not mem.seen[j]:
        mem.seen[j] = True
        mem.visited[mem.n_visited[0]] = j
        mem.n_visited[0] += 1
    mem.reward[j] = r
    mem.next_state[j] = s2


@kernel
def plan(q: FloatArray, n_plan: int, mem: Memory, lr: Learner, state: rng.U64Array,
         i: int) -> None:
    """Dyna-Q: replay ``n_plan`` remembered transitions of uniformly drawn visited pairs.

    The arrays are taken out of their tuples and the stream word kept in a
    local once per call, not once per update (see :func:`q_episode` for why).
    """
    visited, rewards, next_state, phi = mem.visited, mem.reward, mem.next_state, lr.phi
    n_visited = mem.n_visited[0]
    z = state[i]
    for _ in range(n_plan):
        z, bits = rng.split(z)
        j = visited[rng.below_of(rng.uniform_of(bits), n_visited)]
        s, a = j // N_ACTIONS, j % N_ACTIONS
        q_update(q, s, a, rewards[j], next_state[j], lr.alpha, lr.gamma, lr.reward_gain,
                 lr.eta * phi[s, a])
    state[i] = z


class Budget(NamedTuple):
    """How long one agent learns."""

    episodes: int
    """Episodes, each from rest with a freshly drawn target."""
    steps: int
    """Real steps per episode."""
    planning: int
    """Dyna-Q planning updates after each real step (0 = plain Q-learning)."""
    snap_at: IntArray
    """Episode counts (1-based, increasing) after which the Q-table is copied."""


@kernel
def q_episode(model: Kernel, lr: Learner, q: FloatArray, plant: FloatArray, s: int, x: float,
              target: float, steps: int, state: rng.U64Array, i: int) -> float:
    """``steps`` plain Q-learning steps from state ``s`` at ``x``; returns the sum of rewards.

    Exactly :func:`transition` repeated (same draws, same operations, so the
    same bits), arranged for speed: the arrays of ``lr`` and ``model`` are
    taken out of their tuples once, the stream word stays in a local for the
    whole episode, and on the plant its (x, v) stay in locals too. Why: numba
    counts references with atomic instructions, and every call in the loop
    that receives an array and may raise (the model step) or loops (ε-greedy)
    pays an increment and a decrement per array per step — 40 % of a step
    before this function existed.
    """
    actions, phi, enc = lr.actions, lr.phi, lr.enc
    on_plant = model.kind == kernels.KIND_PLANT
    pl = kernels.plant_of(model.params) if on_plant else kernels.Plant(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    limit = model.force_limit
    v = plant[kernels.MOTION]
    z = state[i]
    err = abs(x - target)
    total = 0.0
    for _ in range(steps):
        a, z = pick(q, s, lr.epsilon, z)
        if on_plant:
            x_new, v = kernels.plant_step(pl, x, v, kernels.saturate(actions[a], limit))
        else:
            x_new = kernels.advance(model, plant, actions[a])
        e_new = x_new - target
        if enc.mode == MODE_PAPER:
            s2 = paper_bin(enc.n_states, enc.e_max, e_new)
        else:
            s2 = encode(enc, e_new, x_new - x, target)
        r = reward(lr, abs(e_new), err)
        q_update(q, s, a, r, s2, lr.alpha, lr.gamma, lr.reward_gain, lr.eta * phi[s, a])
        x, err, s = x_new, abs(e_new), s2
        total += r
    state[i] = z
    if on_plant:
        plant[kernels.POS] = x
        plant[kernels.MOTION] = v
    return total


@kernel
def learn_one(model: Kernel, lr: Learner, budget: Budget, q: FloatArray, snaps: FloatArray,
              returns: FloatArray, counts: IntArray, state: rng.U64Array, i: int) -> None:
    """All episodes of agent ``i``; with ``budget.planning > 0`` it is Dyna-Q.

    Writes the final table to ``q``, snapshots to ``snaps``, per-episode return
    sums to ``returns`` and (real steps, planning updates) to ``counts``.
    """
    n_plan = budget.planning
    mem = new_memory(lr.enc.n_states * N_ACTIONS if n_plan > 0 else 0)
    plant = np.zeros(kernels.RIG_STATE_SIZE)
    k_snap = 0
    for ep in range(budget.episodes):
        target = draw_target(lr, state, i)
        plant[:] = 0.0
        x = 0.0
        err = abs(x - target)
        s = encode(lr.enc, x - target, 0.0, target)
        if n_plan == 0:
            returns[ep] = q_episode(model, lr, q, plant, s, x, target, budget.steps, state, i)
            counts[0] += budget.steps
        else:
            total = 0.0
            for _ in range(budget.steps):
                a, x, err, s2, r = transition(model, lr, q, plant, s, x, err, target, state, i)
                remember(mem, s * N_ACTIONS + a, r, s2)
                plan(q, n_plan, mem, lr, state, i)
                counts[0] += 1
                counts[1] += n_plan
                total += r
                s = s2
            returns[ep] = total
        if k_snap < budget.snap_at.size and budget.snap_at[k_snap] == ep + 1:
            snaps[k_snap] = q
            k_snap += 1


@kernel
def normal(state: rng.U64Array, i: int) -> float:
    """A standard normal draw from stream ``i`` (Box–Muller on two uniforms)."""
    u1 = rng.uniform(state, i)
    u2 = rng.uniform(state, i)
    return math.sqrt(-2.0 * math.log(1.0 - u1)) * math.cos(2.0 * math.pi * u2)


OBS_DRIFT = kernels.STATE_MAX
"""Observer state slot of the drift estimate, behind a model state of any kind (``kernels.STATE_MAX``
slots, of which the model's kernel uses its own: :func:`kernels.state_size`)."""
OBS_HISTORY = OBS_DRIFT + 1
"""First observer state slot of the ``obs_delay`` last commanded forces (newest first)."""


@kernel
def observer_state(lr: Learner) -> FloatArray:
    """A zeroed observer state: a model state of any kind, the drift estimate, the ``obs_delay``
    last commanded forces, then the force-bias estimate (last slot).

    Why the model's block is ``kernels.STATE_MAX`` long and not the observed kind's: one layout
    serves every kind (a greybox-rig state is longer than four floats), so no slot of the model's
    own state can collide with the observer's.
    """
    return np.zeros(OBS_HISTORY + lr.obs_delay + 1)


@kernel
def model_state(ost: FloatArray) -> FloatArray:
    """The model's state inside the observer's (a view: the predictor advances it in place)."""
    return ost[:kernels.STATE_MAX]


@kernel
def assumed_force(lr: Learner, ost: FloatArray, u: float) -> float:
    """The force the observer assumes acts now: ``u`` commanded ``obs_delay`` samples ago (0 before).

    Shifts ``u`` into the command history kept behind the drift estimate of ``ost``.
    """
    d = lr.obs_delay
    if d == 0:
        return u
    acting: float = ost[OBS_HISTORY + d - 1]
    for j in range(OBS_HISTORY + d - 1, OBS_HISTORY, -1):
        ost[j] = ost[j - 1]
    ost[OBS_HISTORY] = u
    return acting


@kernel
def bias_slot(ost: FloatArray) -> int:
    """Where a model observer's state keeps its force-bias estimate: the last slot (read by the
    observer that updates it and by :func:`commanded`, which takes it out of the command)."""
    return ost.size - 1


@kernel
def commanded(lr: Learner, ost: FloatArray, u: float, target: float) -> float:
    """The force commanded for the chosen action's force ``u`` towards ``target``: ``u`` itself on a
    bare rig. Under a stated hold loop (``hold_stiffness`` > 0) it also carries the loop's force at the
    set-point, so the loop holds ``target``; with ``obs_bias_feedforward`` it is less the observer's
    force-bias estimate (its last slot), so a force the surrogate does not know (friction, an offset)
    is taken back out. The observer is told the commanded force; its predictor adds the bias back, so
    it predicts the surrogate under the force the table chose plus the loop's."""
    out = u + lr.hold_stiffness * (target - lr.hold_position)
    if lr.obs_bias_feedforward:
        out -= ost[bias_slot(ost)]
    return out


@kernel
def observe(lr: Learner, obs: Kernel, ost: FloatArray, u: float, y: float, xh: float, dh: float,
            first: bool) -> tuple[float, float]:
    """The agent's (position, per-sample displacement) estimate after measurement ``y``.

    ``none``: the raw measurement and its last difference (the improved agent's
    view). ``alpha-beta``: predict with the last displacement, correct by a
    fraction of the innovation. ``model``: run the model ``obs`` (the one the
    agent trains on) from the observer state ``ost`` under the commanded force
    ``u`` as a predictor and correct it by the innovation — a fixed-gain
    Kalman-style observer; it does not differentiate raw samples, so it does
    not multiply the sensor noise, and its prediction follows the force —
    the one commanded ``obs_delay`` samples ago (:func:`assumed_force`), plus
    the force-bias estimate when ``obs_bias_gain`` > 0 (its integral action).
    """
    if first:
        ost[:] = 0.0
        ost[kernels.POS] = y
        ost[kernels.MOTION] = 0.0 if kernels.holds_velocity(kernels.base_kind(obs)) else y
        return y, 0.0
    if lr.observer == OBS_NONE:
        return y, y - xh
    if lr.observer == OBS_ALPHA_BETA:
        pred = xh + dh
        innovation = y - pred
        return pred + lr.obs_gain * innovation, dh + lr.obs_velocity_gain * innovation
    # ost[OBS_DRIFT] holds the drift estimate: added to each prediction, it integrates the
    # innovation, so a steady model mismatch leaves no steady bias.
    acting = assumed_force(lr, ost, u)
    bias = bias_slot(ost)
    ms = model_state(ost)
    if lr.obs_bias_gain > 0.0:
        # The force-bias state: a constant force the model does not know, driving the predictor
        # beside the commanded one (outside the actuator's saturation, like a load).
        pred = kernels.advance_loaded(obs, ms, acting, ost[bias]) + ost[OBS_DRIFT]
    else:
        pred = kernels.advance(obs, ms, acting) + ost[OBS_DRIFT]
    innovation = y - pred
    ost[kernels.POS] = pred + lr.obs_gain * innovation
    ost[OBS_DRIFT] += lr.obs_drift_gain * innovation
    if lr.obs_bias_gain > 0.0:
        # Integral action on the force; held within ±F (a larger load could not be held anyway), so a
        # hard stop's large innovations cannot wind it up.
        f_max = lr.actions[lr.actions.size - 1]
        ost[bias] = min(f_max, max(-f_max, ost[bias] + lr.obs_bias_gain * innovation))
    share = lr.obs_velocity_share
    x, motion = kernels.POS, kernels.MOTION
    if kernels.holds_velocity(kernels.base_kind(obs)):
        # Moving x by L·r moves an ARX model's implied displacement (x_k - x_{k-1}) by L·r too; a
        # plant-structure state holds the velocity apart, so it gets that correction explicitly
        # (plus any extra velocity gain), or an unmodelled force would bias the estimate for good.
        dt = kernels.step_period(obs)
        ost[motion] += (share * lr.obs_gain + lr.obs_velocity_gain) * innovation / dt
        return ost[x], ost[motion] * dt + ost[OBS_DRIFT]
    if share != 1.0:  # keep only share·L·r of the move in the implied displacement
        ost[motion] += (1.0 - share) * lr.obs_gain * innovation
    return ost[x], ost[x] - ost[motion]


@kernel
def learn_observed(model: Kernel, lr: Learner, budget: Budget, q: FloatArray, snaps: FloatArray,
                   returns: FloatArray, counts: IntArray, state: rng.U64Array, i: int) -> None:
    """Q-learning through an observer, under per-episode sensor noise and actuator delay.

    Our robust agent: each episode draws its target, a noise level in
    [0, train_noise] and a delay in {0..train_delay} from the agent's own
    stream, so training stays a pure function of the seed. The state comes
    from the observer on the noisy measurement; the reward from the model's
    true position (training happens on a model, whose truth is known).
    """
    plant = np.zeros(kernels.RIG_STATE_SIZE)
    ost = observer_state(lr)
    drive = np.zeros(lr.train_delay + 2)  # the rig's drive (rig.actuate) without a lag: the delay only
    k_snap = 0
    for ep in range(budget.episodes):
        target = draw_target(lr, state, i)
        sigma = lr.train_noise * rng.uniform(state, i) if lr.train_noise > 0.0 else 0.0
        delay = rng.below(state, i, lr.train_delay + 1) if lr.train_delay > 0 else 0
        plant[:] = 0.0
        drive[:] = 0.0
        x = 0.0
        err = abs(x - target)
        y = x + sigma * normal(state, i) if sigma > 0.0 else x
        xh, dh = observe(lr, model, ost, 0.0, y, 0.0, 0.0, True)
        s = encode(lr.enc, xh - target, dh, target)
        total = 0.0
        for k in range(budget.steps):
            a = choose(q, s, lr.epsilon, state, i)
            u = commanded(lr, ost, lr.actions[a], target)
            x = kernels.advance(model, plant, actuate(drive, k, u, delay, 0.0))
            y = x + sigma * normal(state, i) if sigma > 0.0 else x
            xh, dh = observe(lr, model, ost, u, y, xh, dh, False)
            s2 = encode(lr.enc, xh - target, dh, target)
            e_new = abs(x - target)
            r = reward(lr, e_new, err)
            td_update(q, s, a, r, s2, lr)
            err = e_new
            counts[0] += 1
            total += r
            s = s2
        returns[ep] = total
        if k_snap < budget.snap_at.size and budget.snap_at[k_snap] == ep + 1:
            snaps[k_snap] = q
            k_snap += 1


@kernel(nogil=True)
def train_batch(model: Kernel, lr: Learner, budget: Budget,
                state: rng.U64Array) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
    """One independent agent per stream word; returns (Q, snapshots, returns, counts).

    It releases the GIL (``nogil``) so :func:`msd_bench.core.learning.qtrain.run_batch`
    can train slices of a batch on several cores from threads.
    """
    n = state.size
    n_states = lr.enc.n_states
    q = np.zeros((n, n_states, N_ACTIONS))
    snaps = np.zeros((n, budget.snap_at.size, n_states, N_ACTIONS))
    returns = np.zeros((n, budget.episodes))
    counts = np.zeros((n, 2), dtype=np.int64)
    for i in range(n):
        if lr.observed:
            learn_observed(model, lr, budget, q[i], snaps[i], returns[i], counts[i], state, i)
        else:
            learn_one(model, lr, budget, q[i], snaps[i], returns[i], counts[i], state, i)
    return q, snaps, returns, counts
