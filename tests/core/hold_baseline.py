"""A baseline planted by a test: it holds the equilibrium force of the set-point, open loop.

Its only purpose is to prove that a new baseline is this one module plus one catalogue line
(``tests/core/test_baseline_catalogue.py``): it has the face every baseline module has.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from msd_bench.core.baselines import base
from msd_bench.core.physics import kernels


@dataclass(frozen=True)
class Options:
    """No options but a gain on the held force."""

    gain: float = 1.0


@dataclass(frozen=True)
class HoldDesign:
    force: float

    def as_dict(self) -> dict[str, Any]:
        return {"force": self.force}


def design(model: Any, target: float, force: float, dt: float, opt: Options) -> HoldDesign:
    return HoldDesign(float(np.clip(opt.gain * base.equilibrium_force(model, target), -force, force)))


class Stepwise:
    def __init__(self, d: HoldDesign) -> None:
        self.force = d.force

    def reset(self) -> None:
        pass

    def act(self, y: float) -> float:
        return self.force


def rollout(plant: kernels.Kernel, d: HoldDesign, cond: Any,
            noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xs = np.zeros(noise.shape)
    for j in range(noise.shape[0]):
        state = np.zeros(kernels.state_size(plant.kind))
        for k in range(noise.shape[1]):
            xs[j, k] = kernels.advance(plant, state, d.force)
    return xs, np.full(noise.shape, d.force)
