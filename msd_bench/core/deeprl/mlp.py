"""The trained network's greedy forward pass, in numba, on the agent's own observation.

The observation is what the agent node can build from the plant's
measurements alone, the environment's ``[y, y - y_prev, target, u_prev]``.
The network sees fixed features of it (:func:`features`): the tracking error
and the other entries scaled to about unit size, because an MLP fed a
difference of 1e-3 m beside a force of 10 N learns the force and ignores the
velocity. The scaling is part of the policy, the same in training
(:class:`msd_bench.designs.deeprl_train.Features`) and here.

Both SB3 policies this project trains are two hidden layers and a linear head
over the five forces: DQN's Q-network (ReLU), PPO's actor (tanh, logits).
Greedy is the head's argmax, first index on ties, as ``torch.argmax``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.kernel_cache import kernel

FloatArray = NDArray[np.float64]

RELU = 0
TANH = 1
ACTIVATIONS = {"relu": RELU, "tanh": TANH}
"""Hidden-layer activations by name (DQN's MlpPolicy default is ReLU, PPO's tanh)."""

POS_SCALE = 2.5
"""Positions and set-points are divided by the half stroke, m."""
DY_SCALE = 0.05
"""The per-sample difference is divided by 5 m/s x 10 ms, about the fastest the mass moves."""
FORCE_SCALE = 10.0
"""The last force is divided by the actuator's limit F, N."""
N_FEATURES = 4


class Net(NamedTuple):
    """A stack of policies of one shape: run ``j`` of a batch rollout uses ``w*[j]``, ``b*[j]``."""

    w1: FloatArray
    """(n, h1, 4) first layer weights."""
    b1: FloatArray
    """(n, h1)."""
    w2: FloatArray
    """(n, h2, h1)."""
    b2: FloatArray
    """(n, h2)."""
    w3: FloatArray
    """(n, n_actions, h2): the head (Q-values for DQN, logits for PPO)."""
    b3: FloatArray
    """(n, n_actions)."""
    activation: int
    """:data:`RELU` or :data:`TANH`."""


def check_net(net: Net) -> None:
    """Refuse a stack whose shapes do not chain, or a non-finite weight, with one line."""
    arrays = net[:6]
    if any(not isinstance(a, np.ndarray) or a.dtype != np.float64 for a in arrays):
        raise InvalidInputError("network weights must be float64 arrays")
    w1, b1, w2, b2, w3, b3 = arrays
    n = w1.shape[0] if w1.ndim == 3 else -1
    ok = (w1.ndim == 3 and w1.shape[2] == N_FEATURES and b1.shape == w1.shape[:2]
          and w2.ndim == 3 and w2.shape[:1] == (n,) and w2.shape[2] == w1.shape[1]
          and b2.shape == w2.shape[:2]
          and w3.ndim == 3 and w3.shape[:1] == (n,) and w3.shape[2] == w2.shape[1]
          and b3.shape == w3.shape[:2] and n >= 1 and w3.shape[1] >= 1)
    if not ok:
        raise InvalidInputError("network weights do not chain: need w1 (n,h1,4), b1 (n,h1), w2 (n,h2,h1), "
                                f"b2 (n,h2), w3 (n,a,h2), b3 (n,a); got {[a.shape for a in arrays]}")
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise InvalidInputError("network weights must be finite")
    if net.activation not in (RELU, TANH):
        raise InvalidInputError(f"activation must be {RELU} (relu) or {TANH} (tanh), got {net.activation!r}")


def from_arrays(arrays: list[FloatArray], activation: int) -> Net:
    """A :class:`Net` from its six arrays in order (w1, b1, w2, b2, w3, b3), checked."""
    if len(arrays) != 6:
        raise InvalidInputError(f"a network has six weight arrays, got {len(arrays)}")
    a = [np.ascontiguousarray(x, dtype=np.float64) for x in arrays]
    net = Net(a[0], a[1], a[2], a[3], a[4], a[5], int(activation))
    check_net(net)
    return net


def stack(nets: list[Net]) -> Net:
    """One batch of several single-policy stacks of the same shape (one per seed)."""
    if not nets or len({n.activation for n in nets}) != 1:
        raise InvalidInputError("stack needs at least one network, all with the same activation")
    try:
        arrays = [np.concatenate([n[i] for n in nets]) for i in range(6)]
    except ValueError:
        raise InvalidInputError("cannot stack networks of different sizes") from None
    return from_arrays(arrays, nets[0].activation)


def select(net: Net, j: int) -> Net:
    """Policy ``j`` of a stack as a stack of one."""
    return from_arrays([a[j:j + 1] for a in net[:6]], net.activation)


@kernel
def features(y: float, dy: float, target: float, u_prev: float, out: FloatArray) -> None:
    """The network's input from the observation ``[y, dy, target, u_prev]`` (into ``out``)."""
    out[0] = (y - target) / POS_SCALE
    out[1] = dy / DY_SCALE
    out[2] = target / POS_SCALE
    out[3] = u_prev / FORCE_SCALE


@kernel
def _act(z: float, activation: int) -> float:
    if activation == RELU:
        return z if z > 0.0 else 0.0
    return math.tanh(z)


@kernel
def _layer(w: FloatArray, b: FloatArray, x: FloatArray, out: FloatArray, activation: int) -> None:
    """``out = act(w @ x + b)`` for one policy's layer; ``activation`` < 0 is linear."""
    for i in range(w.shape[0]):
        z = b[i]
        for k in range(w.shape[1]):
            z += w[i, k] * x[k]
        out[i] = _act(z, activation) if activation >= 0 else z


@kernel
def head(net: Net, j: int, feat: FloatArray) -> FloatArray:
    """Policy ``j``'s head outputs (Q-values or logits) on the features ``feat``."""
    h1 = np.empty(net.w1.shape[1])
    h2 = np.empty(net.w2.shape[1])
    out = np.empty(net.w3.shape[1])
    _layer(net.w1[j], net.b1[j], feat, h1, net.activation)
    _layer(net.w2[j], net.b2[j], h1, h2, net.activation)
    _layer(net.w3[j], net.b3[j], h2, out, -1)
    return out


@kernel
def greedy(net: Net, j: int, y: float, dy: float, target: float, u_prev: float) -> int:
    """Policy ``j``'s greedy action index on one observation (first maximum on ties)."""
    feat = np.empty(N_FEATURES)
    features(y, dy, target, u_prev, feat)
    return int(np.argmax(head(net, j, feat)))


def greedy_batch(net: Net, j: int, obs: FloatArray) -> NDArray[np.int64]:
    """Greedy actions of policy ``j`` on each row of ``obs`` (n, 4): the parity test's view."""
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim != 2 or obs.shape[1] != N_FEATURES:
        raise InvalidInputError(f"observations must be (n, 4), got shape {obs.shape}")
    return np.array([greedy(net, j, *row) for row in obs], dtype=np.int64)
