"""Compiled kernels of tabular Q-learning (paper §4), shared with Dyna-Q.

Why compiled: one paper-sized run is 900,000 strictly sequential steps, each a
model step, a state encoding, an ε-greedy choice and a TD update; plain Python
manages 0.05–0.25 M steps/s (benchmarks/bench_training.py). Every function
here is ``numba.njit(cache=True)``, takes the packed arrays of
:func:`msd_bench.core.qconfig.encoding` and steps the model through
:func:`msd_bench.core.kernels.advance`, so the learner trains on any
plant-like model. The Python-facing API is in :mod:`msd_bench.core.qtrain`.

Conventions: ``x[k]`` is the position before action ``k`` acts; the reward of
step k is computed from ``E_{k+1} = |e_{k+1}|`` and ``E_k`` (the *unclipped* error:
the clip to ±e_max applies to the state index only); the last step of an
episode bootstraps (a time limit, not a terminal state); each agent ``i`` draws
all its randomness (targets, exploration, ties) from its own stream ``rng[i]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from msd_bench.core import kernels, rng
from msd_bench.core.qconfig import (
    HP_ALPHA,
    HP_DIRTOL,
    HP_EMAX,
    HP_EPS,
    HP_ETA,
    HP_G,
    HP_GAIN,
    HP_GAMMA,
    HP_LEAD,
    HP_NDIR,
    HP_THIGH,
    HP_TLOW,
    HP_ZETA,
    MODE_PAPER,
    N_ACTIONS,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@numba.njit(cache=True)
def encode(mode: int, n_states: int, hp: FloatArray, err_edges: FloatArray,
           ref_edges: FloatArray, e: float, dx: float, target: float) -> int:
    """State index of error ``e`` (paper), or of (lead error, sign of ``dx``, target bin) (improved)."""
    emax = hp[HP_EMAX]
    if mode == MODE_PAPER:
        ec = min(max(e, -emax), emax)
        return math.floor((n_states - 1) * (ec + emax) / (2.0 * emax) + 0.5)
    eb = np.searchsorted(err_edges, e + hp[HP_LEAD] * dx, side="right")
    n_dir = int(hp[HP_NDIR])
    db = 0
    if n_dir > 1:
        tol = hp[HP_DIRTOL]
        db = 1
        if dx < -tol:
            db = 0
        elif dx > tol:
            db = 2
    rb = np.searchsorted(ref_edges, target, side="right")
    return int((eb * n_dir + db) * (ref_edges.size + 1) + rb)


@numba.njit(cache=True)
def reward(hp: FloatArray, err: float, err_prev: float) -> float:
    """``g / (1 + E_k) - ζ (E_k - E_{k-1}) / E_max`` with ``E = |e|`` (paper eq. 19)."""
    return hp[HP_G] / (1.0 + err) - hp[HP_ZETA] * (err - err_prev) / hp[HP_EMAX]


@numba.njit(cache=True)
def choose(q: FloatArray, s: int, eps: float, state: rng.U64Array, i: int) -> int:
    """ε-greedy action; ties among equal maxima are broken uniformly at random."""
    if rng.uniform(state, i) < eps:
        return rng.below(state, i, N_ACTIONS)
    best = q[s, 0]
    count = 1
    for a in range(1, N_ACTIONS):
        v = q[s, a]
        if v > best:
            best = v
            count = 1
        elif v == best:
            count += 1
    k = rng.below(state, i, count) if count > 1 else 0
    for a in range(N_ACTIONS):
        if q[s, a] == best:
            if k == 0:
                return a
            k -= 1
    return 0  # unreachable: best is one of the row's values


@numba.njit(cache=True)
def greedy(q: FloatArray, s: int) -> int:
    """Deterministic greedy action: the lowest index among equal maxima (like np.argmax)."""
    best = 0
    for a in range(1, N_ACTIONS):
        if q[s, a] > q[s, best]:
            best = a
    return best


@numba.njit(cache=True)
def td_update(q: FloatArray, s: int, a: int, r: float, s2: int, hp: FloatArray,
              phi: FloatArray) -> None:
    """``Q[s,a] += α(A r + γ max Q[s'] − Q[s,a]) − η φ(s,a)`` (shaping as a penalty)."""
    nxt = q[s2, 0]
    for b in range(1, N_ACTIONS):
        nxt = max(nxt, q[s2, b])
    td = hp[HP_GAIN] * r + hp[HP_GAMMA] * nxt - q[s, a]
    q[s, a] += hp[HP_ALPHA] * td - hp[HP_ETA] * phi[s, a]


@numba.njit(cache=True)
def draw_target(hp: FloatArray, state: rng.U64Array, i: int) -> float:
    """Episode target, uniform in [target_low, target_high]."""
    return hp[HP_TLOW] + (hp[HP_THIGH] - hp[HP_TLOW]) * rng.uniform(state, i)


@numba.njit(cache=True)
def transition(kind: int, p: FloatArray, mode: int, n_states: int, hp: FloatArray,
               err_edges: FloatArray, ref_edges: FloatArray, phi: FloatArray, actions: FloatArray,
               q: FloatArray, plant: FloatArray, s: int, x: float, err: float, target: float,
               state: rng.U64Array, i: int) -> tuple[int, float, float, int, float]:
    """One learning step: act ε-greedily, advance the model, score, update Q.

    Returns ``(a, x_new, |e_new|, s_new, r)``. Shared by Q-learning and Dyna-Q so
    both take exactly the same step.
    """
    a = choose(q, s, hp[HP_EPS], state, i)
    x_new = kernels.advance(kind, p, plant, actions[a])
    e_new = x_new - target
    s2 = encode(mode, n_states, hp, err_edges, ref_edges, e_new, x_new - x, target)
    r = reward(hp, abs(e_new), err)
    td_update(q, s, a, r, s2, hp, phi)
    return a, x_new, abs(e_new), s2, r


@numba.njit(cache=True)
def plan(q: FloatArray, n_plan: int, visited: IntArray, n_vis: int, mr: FloatArray,
         ms: IntArray, hp: FloatArray, phi: FloatArray, state: rng.U64Array, i: int) -> None:
    """Dyna-Q: replay ``n_plan`` remembered transitions of uniformly drawn visited pairs."""
    for _ in range(n_plan):
        j = visited[rng.below(state, i, n_vis)]
        td_update(q, j // N_ACTIONS, j % N_ACTIONS, mr[j], ms[j], hp, phi)


@numba.njit(cache=True)
def learn_one(kind: int, p: FloatArray, mode: int, n_states: int, hp: FloatArray,
              err_edges: FloatArray, ref_edges: FloatArray, phi: FloatArray,
              actions: FloatArray, steps: int, n_plan: int, snap_at: IntArray, q: FloatArray,
              snaps: FloatArray, returns: FloatArray, counts: IntArray,
              state: rng.U64Array, i: int) -> None:
    """All episodes of one agent; with ``n_plan > 0`` it is Dyna-Q (Q-learning is n_plan = 0).

    ``counts`` receives (real steps, planning updates).
    """
    n_pairs = n_states * N_ACTIONS
    mr = np.zeros(n_pairs if n_plan > 0 else 0)
    ms = np.zeros(n_pairs if n_plan > 0 else 0, dtype=np.int64)
    seen = np.zeros(n_pairs if n_plan > 0 else 0, dtype=np.bool_)
    visited = np.zeros(n_pairs if n_plan > 0 else 0, dtype=np.int64)
    n_vis = 0
    plant = np.zeros(4)
    k_snap = 0
    for ep in range(returns.size):
        target = draw_target(hp, state, i)
        plant[:] = 0.0
        x = 0.0
        err = abs(x - target)
        s = encode(mode, n_states, hp, err_edges, ref_edges, x - target, 0.0, target)
        total = 0.0
        for _ in range(steps):
            a, x, err, s2, r = transition(kind, p, mode, n_states, hp, err_edges, ref_edges, phi,
                                          actions, q, plant, s, x, err, target, state, i)
            if n_plan > 0:
                j = s * N_ACTIONS + a
                if not seen[j]:
                    seen[j] = True
                    visited[n_vis] = j
                    n_vis += 1
                mr[j] = r
                ms[j] = s2
                plan(q, n_plan, visited, n_vis, mr, ms, hp, phi, state, i)
            counts[0] += 1
            counts[1] += n_plan
            total += r
            s = s2
        returns[ep] = total
        if k_snap < snap_at.size and snap_at[k_snap] == ep + 1:
            snaps[k_snap] = q
            k_snap += 1


@numba.njit(cache=True)
def train_batch(kind: int, p: FloatArray, mode: int, n_states: int, hp: FloatArray,
                err_edges: FloatArray, ref_edges: FloatArray, phi: FloatArray,
                actions: FloatArray, episodes: int, steps: int, n_plan: int, snap_at: IntArray,
                state: rng.U64Array) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
    """One independent agent per stream word; returns (Q, snapshots, returns, counts)."""
    n = state.size
    q = np.zeros((n, n_states, N_ACTIONS))
    snaps = np.zeros((n, snap_at.size, n_states, N_ACTIONS))
    returns = np.zeros((n, episodes))
    counts = np.zeros((n, 2), dtype=np.int64)
    for i in range(n):
        learn_one(kind, p, mode, n_states, hp, err_edges, ref_edges, phi, actions, steps, n_plan,
                  snap_at, q[i], snaps[i], returns[i], counts[i], state, i)
    return q, snaps, returns, counts


@numba.njit(cache=True)
def greedy_batch(kind: int, p: FloatArray, mode: int, n_states: int, hp: FloatArray,
                 err_edges: FloatArray, ref_edges: FloatArray, actions: FloatArray,
                 q: FloatArray, target: float, n_steps: int) -> tuple[FloatArray, FloatArray]:
    """Fixed-table greedy closed loop from rest for each table ``q[j]``; returns (x, u)."""
    n = q.shape[0]
    xs = np.empty((n, n_steps))
    us = np.empty((n, n_steps))
    plant = np.zeros(4)
    for j in range(n):
        plant[:] = 0.0
        x = 0.0
        s = encode(mode, n_states, hp, err_edges, ref_edges, x - target, 0.0, target)
        for k in range(n_steps):
            u = actions[greedy(q[j], s)]
            xs[j, k] = x
            us[j, k] = u
            x_new = kernels.advance(kind, p, plant, u)
            s = encode(mode, n_states, hp, err_edges, ref_edges, x_new - target, x_new - x,
                       target)
            x = x_new
    return xs, us
