"""The greybox-rig rollout's own loop is the stepwise kernel (``advance``), bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.physics import kernels


def _model(delay: int, tau: float, friction: float) -> kernels.Kernel:
    params = np.array([1.1, 0.9, 2.3, 1.0, 1.2, 5.0, 10.0, 0.01, friction, tau, float(delay)])
    return kernels.Kernel(kernels.KIND_GREYBOX_RIG, params, 10.0)


@pytest.mark.parametrize("delay", [0, 1, 2])
@pytest.mark.parametrize("tau", [0.0, 0.013, 0.04])
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_the_rollout_is_the_stepwise_kernel_bit_for_bit(delay: int, tau: float, friction: float) -> None:
    rng = np.random.default_rng(delay * 100 + int(1000 * tau) + int(10 * friction))
    u = np.repeat(rng.choice([-10.0, -5.0, 0.0, 5.0, 10.0, 14.0], 300), 7)  # 14 N saturates
    model = _model(delay, tau, friction)
    start = np.zeros(kernels.RIG_STATE_SIZE)
    start[0], start[1] = 0.3, -0.2
    rolled, stepped = start.copy(), start.copy()
    x = kernels.rollout(model, u, rolled)
    expected = np.empty(u.size)
    for k in range(u.size):
        expected[k] = stepped[0]
        kernels.advance(model, stepped, float(u[k]))
    assert np.array_equal(x, expected)
    assert np.array_equal(rolled, stepped)  # the state left behind, delay line and actuator included
    assert np.ptp(x) > 0.5  # the record moves (and touches the stops somewhere for some seeds)
