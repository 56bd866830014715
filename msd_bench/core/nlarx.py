"""NLARX surrogate of the paper (§3.3): a sigmoid network on a second-order regressor.

``x_{k+1} = xs (c0 + w.phi + sum_j alpha_j sigmoid(beta_j.phi + beta0_j))`` with
``phi = [x_k/xs, x_{k-1}/xs, u_k/us, u_{k-1}/us]`` — the paper's
``x_k = F(x_{k-1}, x_{k-2}, u_{k-1}, u_{k-2})`` shifted by one sample, and
exactly the ``KIND_NLARX`` kernel layout (:mod:`msd_bench.core.kernels`).

Two forms (docs/decisions.md §NLARX):

* ``paper`` — sigmoid units only (``w = 0``), trained on the one-step
  prediction error with mild weight decay (full-batch L-BFGS). Excellent
  one-step fit, poor and seed-dependent simulation fit: the network spends its
  accuracy on ``x_{k+1} ≈ x_k``, not on the tiny second difference that
  carries the dynamics.
* ``improved`` — a linear term plus sigmoid units, *preconditioned*: the torch
  module learns the second difference ``x_{k+1} - 2 x_k + x_{k-1}`` (scaled by
  its spread) from ``[x_k, (x_k - x_{k-1})/δ, u_k, u_{k-1}]`` (position, a
  scaled velocity, forces). This is an invertible linear change of
  coordinates, so the module's :meth:`NlarxNet.effective` weights are the
  kernel's weights and its forward pass *is* the kernel formula. Trained
  one-step first (samples touching the hard stops left out, where the plant
  zeroes the velocity and no smooth map fits), then on the multi-step
  simulation error over batched truncated rollouts from measured initial
  states, clamped at the stops like the kernel. The simulation stage is kept
  only if it improves the free-run fit on the training record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from msd_bench.core import kernels
from msd_bench.core.data import Experiment
from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.fit import fit_percent

FloatArray = NDArray[np.float64]
FORMS = ("paper", "improved")


@dataclass(frozen=True)
class NlarxConfig:
    """Training of the NLARX surrogate (paper §3.3; ``improved`` is our extension)."""

    form: str = "paper"
    """``"paper"`` (sigmoids only, one-step error) or ``"improved"`` (linear term, simulation error)."""
    units: int = 10
    """Number of sigmoid units S (paper: a shallow network; 10 by default)."""
    seed: int = 0
    """Seeds the weight initialisation and the window sampling: same seed, same model."""
    weight_decay: float = 1e-6
    """L2 penalty on the sigmoid weights in the one-step stage (the paper's "mild regularization")."""
    one_step_iters: int = 300
    """Maximum L-BFGS iterations of the one-step stage."""
    sim_iters: int = 120
    """Adam iterations of the simulation-error stage (``improved`` only; 0 skips it)."""
    horizon: int = 200
    """Samples per truncated rollout in the simulation stage (2 s at 0.01 s)."""
    batch: int = 64
    """Rollout windows per Adam iteration."""
    lr: float = 3e-4
    """Adam learning rate of the simulation stage."""
    threads: int = 1
    """torch CPU threads (the bench machine has 2 cores, shared)."""

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise ConfigError(f"NLARX form must be one of {FORMS}, got {self.form!r}")
        for name in ("units", "one_step_iters", "horizon", "batch", "threads"):
            if getattr(self, name) < 1:
                raise ConfigError(f"NLARX {name} must be >= 1, got {getattr(self, name)}")
        if self.sim_iters < 0 or self.weight_decay < 0 or not self.lr > 0:
            raise ConfigError("NLARX sim_iters and weight_decay must be >= 0 and lr > 0")


class NlarxNet(torch.nn.Module):
    """The NLARX map in torch; :meth:`effective` gives the kernel's weights exactly."""

    m: torch.Tensor
    base: torch.Tensor
    w: torch.Tensor

    def __init__(self, units: int, improved: bool, delta: float, eps: float, gen: torch.Generator):
        super().__init__()
        dd = torch.float64
        self.improved = improved
        m = torch.eye(4, dtype=dd)
        if improved:  # z = [x_k, (x_k - x_{k-1})/δ, u_k, u_{k-1}] (scaled)
            m[1, 0], m[1, 1] = 1.0 / delta, -1.0 / delta
        self.register_buffer("m", m)
        base = [2.0, -1.0, 0.0, 0.0] if improved else [0.0] * 4
        self.register_buffer("base", torch.tensor(base, dtype=dd))
        self.out_scale = eps if improved else 1.0
        self.c = torch.nn.Parameter(torch.zeros((), dtype=dd))
        if improved:
            self.w = torch.nn.Parameter(torch.zeros(4, dtype=dd))
        else:  # the paper form has no linear term: a constant zero, not a weight
            self.register_buffer("w", torch.zeros(4, dtype=dd))
        self.beta = torch.nn.Parameter(torch.randn(units, 4, generator=gen, dtype=dd))
        self.beta0 = torch.nn.Parameter(torch.randn(units, generator=gen, dtype=dd))
        a0 = 0.01 if improved else 0.1
        self.alpha = torch.nn.Parameter(a0 * torch.randn(units, generator=gen, dtype=dd))

    def effective(self) -> tuple[torch.Tensor, ...]:
        """``(c0, w, alpha, beta, beta0)`` in the kernel's (scaled ``phi``) coordinates."""
        s = self.out_scale
        w = self.base + s * (self.m.T @ self.w)
        return s * self.c, w, s * self.alpha, self.beta @ self.m, self.beta0

    def forward(self, phi: torch.Tensor) -> torch.Tensor:
        """Scaled ``x_{k+1}/xs`` from rows of scaled ``phi`` — the kernel formula."""
        c0, w, alpha, beta, beta0 = self.effective()
        return c0 + phi @ w + torch.sigmoid(phi @ beta.T + beta0) @ alpha

    def kernel_params(self, stroke: float, xs: float, us: float) -> FloatArray:
        """Packed ``KIND_NLARX`` parameters."""
        c0, w, alpha, beta, beta0 = (t.detach().numpy() for t in self.effective())
        units = np.column_stack([alpha, beta, beta0]).ravel()
        return np.concatenate([[stroke, alpha.size, xs, us, float(c0)], w, units])


def fit_nlarx(
    experiments: tuple[Experiment, ...], stroke: float, cfg: NlarxConfig
) -> tuple[FloatArray, dict[str, object]]:
    """Train on ``experiments``; return packed kernel parameters and facts for ``info``."""
    torch.set_num_threads(cfg.threads)
    y = np.concatenate([e.y for e in experiments])
    u = np.concatenate([e.u for e in experiments])
    xs, us = float(np.std(y)), float(np.std(u))
    if xs == 0.0 or us == 0.0:
        raise IdentificationError("NLARX needs a record where both force and position vary")
    phi, target, free = _regressors(experiments, xs, us, stroke)
    second = target - 2 * phi[:, 0] + phi[:, 1]
    delta = float(torch.std(phi[:, 0] - phi[:, 1]))
    eps = float(torch.std(second))
    gen = torch.Generator().manual_seed(cfg.seed)
    net = NlarxNet(cfg.units, cfg.form == "improved", max(delta, 1e-12), max(eps, 1e-12), gen)
    if net.improved:
        if int(free.sum()) < cfg.units + 5:
            raise IdentificationError("NLARX record spends almost all its time at the hard stops")
        phi, target = phi[free], target[free]
        _init_linear(net, phi, target)
    _one_step(net, phi, target, cfg)
    params = net.kernel_params(stroke, xs, us)
    info: dict[str, object] = {"form": cfg.form, "units": cfg.units, "seed": cfg.seed}
    if net.improved and cfg.sim_iters > 0:
        before = _train_fit(params, experiments)
        _simulation_stage(net, experiments, xs, us, stroke, cfg)
        refined = net.kernel_params(stroke, xs, us)
        after = _train_fit(refined, experiments)
        info.update(train_sim_fit_one_step_stage=before, train_sim_fit_sim_stage=after)
        if after >= before:
            params = refined
        info["sim_stage_kept"] = bool(after >= before)
    if not np.all(np.isfinite(params)):
        raise IdentificationError("NLARX training diverged (non-finite weights)")
    return params, info


def _regressors(
    experiments: tuple[Experiment, ...], xs: float, us: float, stroke: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Scaled ``phi_k`` rows, targets ``x_{k+1}/xs`` and a mask of rows clear of the stops."""
    rows, targets, free = [], [], []
    lim = 0.5 * stroke - 1e-9
    for e in experiments:
        x, u = e.y / xs, e.u / us
        rows.append(np.column_stack([x[1:-1], x[:-2], u[1:-1], u[:-2]]))
        targets.append(x[2:])
        inside = np.abs(e.y) < lim
        free.append(inside[2:] & inside[1:-1] & inside[:-2])
    return (
        torch.from_numpy(np.vstack(rows)),
        torch.from_numpy(np.concatenate(targets)),
        torch.from_numpy(np.concatenate(free)),
    )


def _init_linear(net: NlarxNet, phi: torch.Tensor, target: torch.Tensor) -> None:
    """Least-squares linear part on the preconditioned second difference.

    numpy, not ``torch.linalg.lstsq``: the MKL solver behind the latter gave
    last-bit differences on the first call of a process, which L-BFGS then
    amplified, and a seed must always give the same model.
    """
    p = phi.numpy()
    z = p @ net.m.numpy().T
    d2 = (target.numpy() - 2 * p[:, 0] + p[:, 1]) / net.out_scale
    sol = np.linalg.lstsq(np.column_stack([z, np.ones(len(z))]), d2, rcond=None)[0]
    with torch.no_grad():
        net.w.copy_(torch.from_numpy(sol[:4]))
        net.c.copy_(torch.tensor(sol[4], dtype=torch.float64))


def _one_step(net: NlarxNet, phi: torch.Tensor, target: torch.Tensor, cfg: NlarxConfig) -> None:
    """Full-batch L-BFGS on the (scaled) one-step prediction error plus weight decay."""
    params = [p for p in net.parameters() if p.requires_grad]
    opt = torch.optim.LBFGS(
        params, lr=1.0, max_iter=cfg.one_step_iters, history_size=20, line_search_fn="strong_wolfe"
    )
    scale = net.out_scale

    def closure() -> torch.Tensor:
        opt.zero_grad()
        err = (net(phi) - target) / scale
        decay = net.beta.square().sum() + net.alpha.square().sum()
        loss = torch.mean(err.square()) + cfg.weight_decay * decay
        loss.backward()
        return loss

    opt.step(closure)


def _simulation_stage(
    net: NlarxNet,
    experiments: tuple[Experiment, ...],
    xs: float,
    us: float,
    stroke: float,
    cfg: NlarxConfig,
) -> None:
    """Adam on the mean squared free-run error of batched truncated rollouts."""
    x = torch.from_numpy(np.concatenate([e.y for e in experiments]) / xs)
    u = torch.from_numpy(np.concatenate([e.u for e in experiments]) / us)
    horizon = min(cfg.horizon, min(len(e) for e in experiments) - 2)
    starts = _window_starts(experiments, horizon)
    lim = 0.5 * stroke / xs
    gen = torch.Generator().manual_seed(cfg.seed + 1)
    opt = torch.optim.Adam([p for p in net.parameters() if p.requires_grad], lr=cfg.lr)
    steps = torch.arange(horizon)
    for _ in range(cfg.sim_iters):
        st = starts[torch.randint(len(starts), (cfg.batch,), generator=gen)]
        idx = st[:, None] + steps[None, :]
        pred = _rollout(net, x[st], x[st - 1], u[idx], u[st - 1], lim)
        loss = torch.mean((pred - x[idx + 1]).square())
        opt.zero_grad()
        loss.backward()
        opt.step()


def _rollout(
    net: NlarxNet, xk: torch.Tensor, xp: torch.Tensor, uw: torch.Tensor, up: torch.Tensor, lim: float
) -> torch.Tensor:
    """Free run over ``uw`` (batch x horizon) from measured ``(x_k, x_{k-1}, u_{k-1})``."""
    c0, w, alpha, beta, beta0 = net.effective()
    outs = []
    for k in range(uw.shape[1]):
        phi = torch.stack([xk, xp, uw[:, k], up], 1)
        xn = torch.clamp(c0 + phi @ w + torch.sigmoid(phi @ beta.T + beta0) @ alpha, -lim, lim)
        outs.append(xn)
        xp, xk, up = xk, xn, uw[:, k]
    return torch.stack(outs, 1)


def _window_starts(experiments: tuple[Experiment, ...], horizon: int) -> torch.Tensor:
    """Indices k (in the concatenation) with k-1 and k+horizon inside one experiment."""
    out, offset = [], 0
    for e in experiments:
        out.append(np.arange(offset + 1, offset + len(e) - horizon))
        offset += len(e)
    starts = np.concatenate(out)
    if starts.size == 0:
        raise IdentificationError("records are too short for the NLARX simulation stage")
    return torch.from_numpy(starts)


def _train_fit(params: FloatArray, experiments: tuple[Experiment, ...]) -> float:
    """Free-run fit on the training record from measured initial states (the stage guard)."""
    ys, yh = [], []
    for e in experiments:
        state = np.array([e.y[1], e.y[0], e.u[0], 0.0])
        # the record holds the forces that acted, so no further limit applies
        sim = kernels.rollout(kernels.Kernel(kernels.KIND_NLARX, params, np.inf), e.u[1:], state)
        ys.append(e.y)
        yh.append(np.concatenate([e.y[:1], sim]))
    return fit_percent(np.concatenate(ys), np.concatenate(yh))
