"""The compiled rollout gradient of the NLARX simulation stage against torch autograd."""

from __future__ import annotations

import numpy as np
import torch

from msd_bench.core.identification.nlarx import NlarxNet, _compiled_backward, _rollout


def _setup(lim: float) -> tuple[NlarxNet, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    gen = torch.Generator().manual_seed(5)
    net = NlarxNet(6, True, 0.05, 0.01, gen)
    with torch.no_grad():  # a non-trivial linear part, as after the one-step stage
        net.w.copy_(torch.tensor([-0.3, 0.2, 0.5, 0.1], dtype=torch.float64))
    rng = np.random.default_rng(1)
    n = 600
    x = torch.from_numpy(np.cumsum(rng.standard_normal(n)) * 0.05)
    xf = x + torch.from_numpy(rng.standard_normal(n) * 1e-3)
    u = torch.from_numpy(rng.standard_normal(n))
    st = torch.from_numpy(rng.integers(1, n - 60, 16))
    return net, x, xf, u, st


def _grads(net: NlarxNet) -> list[np.ndarray]:
    return [p.grad.numpy().copy() for p in net.parameters() if p.grad is not None]


def _torch_grads(net: NlarxNet, x, xf, u, st, horizon: int, lim: float) -> list[np.ndarray]:
    net.zero_grad()
    idx = st[:, None] + torch.arange(horizon)[None, :]
    pred = _rollout(net, xf[st], xf[st - 1], u[idx], u[st - 1], lim)
    torch.mean((pred - x[idx + 1]).square()).backward()
    return _grads(net)


def test_compiled_gradient_is_torchs() -> None:
    net, x, xf, u, st = _setup(lim=1e3)
    ref = _torch_grads(net, x, xf, u, st, 50, 1e3)
    net.zero_grad()
    _compiled_backward(net, x, xf, u, st, 50, 1e3)
    got = _grads(net)
    assert len(got) == len(ref) == 5
    for a, b in zip(got, ref, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-14)


def test_compiled_gradient_is_torchs_where_the_rollout_hits_the_stops() -> None:
    net, x, xf, u, st = _setup(lim=0.3)
    assert float(x.abs().max()) > 0.3  # some windows are clamped
    ref = _torch_grads(net, x, xf, u, st, 50, 0.3)
    net.zero_grad()
    _compiled_backward(net, x, xf, u, st, 50, 0.3)
    for a, b in zip(_grads(net), ref, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-14)


def test_compiled_one_step_loss_and_gradient_are_torchs() -> None:
    from msd_bench.core.identification.nlarx import one_step_compiled, one_step_torch

    for improved in (True, False):
        gen = torch.Generator().manual_seed(3)
        net = NlarxNet(10, improved, 0.05, 0.01, gen)
        rng = np.random.default_rng(2)
        phi = torch.from_numpy(rng.standard_normal((500, 4)))
        target = torch.from_numpy(rng.standard_normal(500) * 0.1)
        net.zero_grad()
        ref_loss = float(one_step_torch(net, phi, target, 1e-3).detach())
        ref = _grads(net)
        net.zero_grad()
        got_loss = float(one_step_compiled(net, phi, target, 1e-3))
        got = _grads(net)
        assert got_loss == ref_loss or abs(got_loss - ref_loss) <= 1e-12 * abs(ref_loss)
        assert len(got) == len(ref) == (5 if improved else 4)
        for a, b in zip(got, ref, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-14)
