"""A tiny deterministic per-agent random stream usable inside numba.

Why not ``np.random``: inside compiled code numba keeps one global generator
per thread, so a batch of agents would share (and interleave) one stream and a
batched run could never equal a single run for the same seed. Each agent here
owns a ``uint64`` word (one element of an array) advanced by splitmix64
(Steele, Lea & Flood 2014; the seeder of xoshiro), which is fast, passes
BigCrush as a stream, and mixes consecutive seeds into unrelated sequences.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.kernel_cache import kernel

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_INV_2_53 = 1.0 / 9007199254740992.0

U64Array = NDArray[np.uint64]


def seed_states(seeds: Sequence[int]) -> U64Array:
    """One stream word per seed (seeds must be integers in [0, 2^64))."""
    out = np.empty(len(seeds), dtype=np.uint64)
    for i, seed in enumerate(seeds):
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
            raise InvalidInputError(f"seed must be an integer, got {seed!r}")
        if not 0 <= int(seed) < 2**64:
            raise InvalidInputError(f"seed must be in [0, 2^64), got {seed}")
        out[i] = np.uint64(int(seed))
    return out


@kernel
def split(z: np.uint64) -> tuple[np.uint64, np.uint64]:
    """One splitmix64 step of a stream word held in a local: (the next word, 64 random bits).

    Why a scalar form: a hot loop that keeps its agent's word in a register
    (loaded once per episode) avoids a load and a store per draw; the array
    forms below are this same step applied to ``state[i]``.
    """
    z = z + _GOLDEN
    y = (z ^ (z >> _S30)) * _MIX1
    y = (y ^ (y >> _S27)) * _MIX2
    bits: np.uint64 = y ^ (y >> _S31)
    return z, bits


@kernel
def uniform_of(bits: np.uint64) -> float:
    """The float in [0, 1) that 64 random bits stand for (their top 53 bits)."""
    return float(bits >> _S11) * _INV_2_53


@kernel
def below_of(u: float, n: int) -> int:
    """The integer in {0, ..., n-1} that uniform ``u`` stands for (bias < n / 2^53)."""
    k = int(u * n)
    if k >= n:  # rounding of u * n up to n when u is within 2^-53 of 1
        k = n - 1
    return k


@kernel
def next_u64(state: U64Array, i: int) -> np.uint64:
    """Advance stream ``i`` (the word ``state[i]``) and return 64 random bits."""
    z, bits = split(state[i])
    state[i] = z
    return bits


@kernel
def uniform(state: U64Array, i: int) -> float:
    """A float uniform in [0, 1) with 53 random bits, from stream ``i``."""
    return uniform_of(next_u64(state, i))


@kernel
def below(state: U64Array, i: int, n: int) -> int:
    """An integer uniform in {0, ..., n-1} from stream ``i``."""
    return below_of(uniform(state, i), n)
