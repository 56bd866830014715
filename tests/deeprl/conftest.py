"""Deep-RL fixtures: random networks of the policies' shapes, and tiny trained SB3 models."""

from __future__ import annotations

import numpy as np

from msd_bench.core.deeprl import mlp


def random_net(seed: int, n: int = 1, hidden: tuple[int, int] = (16, 16), activation: int = mlp.RELU,
               scale: float = 1.0) -> mlp.Net:
    """``n`` policies with Gaussian weights: varied greedy actions without any training."""
    rng = np.random.default_rng(seed)
    h1, h2 = hidden
    shapes = [(n, h1, 4), (n, h1), (n, h2, h1), (n, h2), (n, 5, h2), (n, 5)]
    return mlp.from_arrays([scale * rng.standard_normal(s) for s in shapes], activation)
