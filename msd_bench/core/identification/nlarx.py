"""NLARX surrogate of the paper (§3.3): a sigmoid network on a second-order regressor.

``x_{k+1} = xs (c0 + w.phi + sum_j alpha_j sigmoid(beta_j.phi + beta0_j))`` with
``phi = [x_k/xs, x_{k-1}/xs, u_k/us, u_{k-1}/us]`` — the paper's
``x_k = F(x_{k-1}, x_{k-2}, u_{k-1}, u_{k-2})`` shifted by one sample, and
exactly the ``KIND_NLARX`` kernel layout (:mod:`msd_bench.core.physics.kernels`).

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

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import torch
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification import nlarx_grad
from msd_bench.core.identification.data import Experiment
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.physics import kernels
from msd_bench.core.physics.sensor import clear_of_stops, lowpass, lowpass_reach, noise_level

if TYPE_CHECKING:
    from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]
FORMS = ("paper", "improved")
NUMERICS = ("compiled", "torch")


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
    numerics: str = "compiled"
    """``"compiled"``: the simulation stage's rollouts and their gradient in compiled code
    (:mod:`msd_bench.core.identification.nlarx_grad`); ``"torch"``: through torch autograd (the earlier
    path, kept
    for the speed benchmark). Same loss and optimiser either way (docs/decisions.md §Identification speed)."""
    prefilter_hz: float = 4.0
    """``improved`` only: cut-off of the zero-phase low-pass applied to force and position for
    the one-step stage and to the positions that start each rollout, Hz (0 = never filter)."""
    prefilter_above: float = 0.05
    """``improved`` only: filter when the estimated sensor noise on a second difference,
    ``sqrt(6) σ``, exceeds this fraction of the record's second-difference spread.
    Noise-free records (about 0.005) stay raw, so their fits are unchanged; 2 mm gives about 1."""

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise ConfigError(f"NLARX form must be one of {FORMS}, got {self.form!r}")
        if self.numerics not in NUMERICS:
            raise ConfigError(f"NLARX numerics must be one of {NUMERICS}, got {self.numerics!r}")
        for name in ("units", "one_step_iters", "horizon", "batch", "threads"):
            if getattr(self, name) < 1:
                raise ConfigError(f"NLARX {name} must be >= 1, got {getattr(self, name)}")
        if self.sim_iters < 0 or self.weight_decay < 0 or not self.lr > 0:
            raise ConfigError("NLARX sim_iters and weight_decay must be >= 0 and lr > 0")
        for name in ("prefilter_hz", "prefilter_above"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ConfigError(f"NLARX {name} must be finite and >= 0, got {value}")


    def scaled(self, scales: Scales) -> NlarxConfig:
        """This training on a rig of ``scales`` (docs/decisions.md §Scales): the prefilter's cut-off the
        same in the rig's time unit, the rollout horizon the same duration. Positions and forces are
        normalised by the record's own spread already. Itself on the paper's plant."""
        if scales.is_default:
            return self
        return replace(self, prefilter_hz=self.prefilter_hz / scales.pace,
                       horizon=scales.samples(self.horizon))


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
        """Scaled ``x_{k+1}/xs`` from rows of scaled ``phi`` — the kernel formula.

        The paper form has no linear term (``w`` is a constant zero), so ``phi @ w`` is left out
        there: adding its exact zeros changes no bit (the models are the same to the last bit), and
        it saves a few per cent of each loss evaluation of the form's one-step stage."""
        c0, w, alpha, beta, beta0 = self.effective()
        hidden = torch.sigmoid(phi @ beta.T + beta0) @ alpha
        return c0 + phi @ w + hidden if self.improved else c0 + hidden

    def kernel_params(self, stroke: float, xs: float, us: float) -> FloatArray:
        """Packed ``KIND_NLARX`` parameters."""
        c0, w, alpha, beta, beta0 = (t.detach().numpy() for t in self.effective())
        units = np.column_stack([alpha, beta, beta0]).ravel()
        return np.concatenate([[stroke, alpha.size, xs, us, float(c0)], w, units])


def fit_nlarx(
    experiments: tuple[Experiment, ...], stroke: float, cfg: NlarxConfig, dt: float = 0.01
) -> tuple[FloatArray, dict[str, object]]:
    """Train on ``experiments`` (sampled at ``dt``); return packed kernel parameters and ``info`` facts."""
    torch.set_num_threads(cfg.threads)
    y = np.concatenate([e.y for e in experiments])
    u = np.concatenate([e.u for e in experiments])
    xs, us = float(np.std(y)), float(np.std(u))
    if xs == 0.0 or us == 0.0:
        raise IdentificationError("NLARX needs a record where both force and position vary")
    improved = cfg.form == "improved"
    ratio = _noise_ratio(experiments)
    band = power_band_hz(experiments, dt)
    # A cut-off inside the band that carries the output would filter the dynamics out with the noise
    # (the Silverbox: 4 Hz against a 69 Hz resonance): then the records stay raw.
    hz = cfg.prefilter_hz if improved and ratio > cfg.prefilter_above and band < cfg.prefilter_hz else 0.0
    smooth = _smoothed(experiments, dt, hz)
    phi, target, free = _regressors(smooth, xs, us, stroke, [_free(e, stroke, dt, hz) for e in experiments])
    second = target - 2 * phi[:, 0] + phi[:, 1]
    delta = float(torch.std(phi[:, 0] - phi[:, 1]))
    eps = float(torch.std(second))
    gen = torch.Generator().manual_seed(cfg.seed)
    net = NlarxNet(cfg.units, improved, max(delta, 1e-12), max(eps, 1e-12), gen)
    if net.improved:
        if int(free.sum()) < cfg.units + 5:
            raise IdentificationError("NLARX record spends almost all its time at the hard stops")
        phi, target = phi[free], target[free]
        _init_linear(net, phi, target)
    _one_step(net, phi, target, cfg)
    params = net.kernel_params(stroke, xs, us)
    info: dict[str, object] = {"form": cfg.form, "units": cfg.units, "seed": cfg.seed}
    if net.improved:
        info.update(prefilter_hz=hz, noise_ratio=ratio, output_band_hz=band)
    if net.improved and cfg.sim_iters > 0:
        before = _train_fit(params, experiments, smooth)
        _simulation_stage(net, experiments, smooth, xs, us, stroke, cfg)
        refined = net.kernel_params(stroke, xs, us)
        after = _train_fit(refined, experiments, smooth)
        info.update(train_sim_fit_one_step_stage=before, train_sim_fit_sim_stage=after)
        if after >= before:
            params = refined
        info["sim_stage_kept"] = bool(after >= before)
    if not np.all(np.isfinite(params)):
        raise IdentificationError("NLARX training diverged (non-finite weights)")
    return params, info


def _noise_ratio(experiments: tuple[Experiment, ...]) -> float:
    """Estimated sensor noise on a second difference over the second difference's spread."""
    y = np.concatenate([e.y for e in experiments])
    spread = float(np.std(np.concatenate([np.diff(e.y, 2) for e in experiments])))
    return float(np.sqrt(6.0) * noise_level(y) / spread) if spread > 0 else 0.0


POWER_SHARE = 0.99
"""Share of the output's power (mean removed) whose band :func:`power_band_hz` reports."""


def power_band_hz(experiments: tuple[Experiment, ...], dt: float) -> float:
    """The frequency below which :data:`POWER_SHARE` of the recorded output's power lies, Hz.

    Why: the improved form's noise prefilter has a fixed cut-off; where the record's own motion
    reaches past it (a rig resonating far faster than the default plant) the filter would take the
    dynamics away, so :func:`fit_nlarx` leaves such records raw. Sensor noise spreads thinly over
    all frequencies and moves this band little.
    """
    freqs, power = [], []
    for e in experiments:
        spec = np.abs(np.fft.rfft(e.y - np.mean(e.y))) ** 2
        freqs.append(np.fft.rfftfreq(e.y.size, dt))
        power.append(spec)
    f, p = np.concatenate(freqs), np.concatenate(power)
    order = np.argsort(f)
    cum = np.cumsum(p[order])
    if cum[-1] <= 0:
        return 0.0
    return float(f[order][np.searchsorted(cum, POWER_SHARE * cum[-1])])


def _smoothed(experiments: tuple[Experiment, ...], dt: float, hz: float) -> tuple[Experiment, ...]:
    """Force and position through one zero-phase low-pass (the records themselves when ``hz`` is 0).

    Why: the one-step stage learns a second difference of about 1 mm; 2 mm of
    sensor noise is about 5 mm on it, and raw regressors then bias every
    weight. Filtering force and position alike keeps them aligned (no lag)
    and, at a cut-off above the plant's modes, changes the dynamics little.
    """
    if hz <= 0:
        return experiments
    return tuple(Experiment(lowpass(e.u, dt, hz), lowpass(e.y, dt, hz), e.name) for e in experiments)


def _free(e: Experiment, stroke: float, dt: float, hz: float) -> NDArray[np.bool_]:
    """Samples clear of the stops (by a noise margin, and by the filter's reach when filtered)."""
    if hz <= 0:
        return np.asarray(np.abs(e.y) < 0.5 * stroke - 1e-9)
    return clear_of_stops(e.y, stroke, lowpass_reach(dt, hz))


def _regressors(
    experiments: tuple[Experiment, ...], xs: float, us: float, stroke: float, inside: list[NDArray[np.bool_]]
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Scaled ``phi_k`` rows, targets ``x_{k+1}/xs`` and a mask of rows clear of the stops."""
    rows, targets, free = [], [], []
    for e, ok in zip(experiments, inside, strict=True):
        x, u = e.y / xs, e.u / us
        rows.append(np.column_stack([x[1:-1], x[:-2], u[1:-1], u[:-2]]))
        targets.append(x[2:])
        free.append(ok[2:] & ok[1:-1] & ok[:-2])
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
    # The paper form keeps torch's loss: its free-run fit hangs on the last bits of this stage (a
    # different summation order moved id seed 1's validation fit from -76 % to 9 %), so the compiled
    # one would change its reported results by chance, not by design.
    loss = one_step_compiled if cfg.numerics == "compiled" and net.improved else one_step_torch

    def closure() -> torch.Tensor:
        opt.zero_grad()
        return loss(net, phi, target, cfg.weight_decay)

    opt.step(closure)


def one_step_torch(net: NlarxNet, phi: torch.Tensor, target: torch.Tensor,
                   weight_decay: float) -> torch.Tensor:
    """The one-step stage's loss, its gradient accumulated in ``net`` by torch autograd."""
    err = (net(phi) - target) / net.out_scale
    decay = net.beta.square().sum() + net.alpha.square().sum()
    loss = torch.mean(err.square()) + weight_decay * decay
    loss.backward()
    return loss


def one_step_compiled(net: NlarxNet, phi: torch.Tensor, target: torch.Tensor,
                      weight_decay: float) -> torch.Tensor:
    """:func:`one_step_torch` with the prediction error and its gradient by the effective weights in
    compiled code (:func:`msd_bench.core.identification.nlarx_grad.one_step_loss_grad`); torch maps that
    gradient onto the parameters through :meth:`NlarxNet.effective` and adds the weight decay's."""
    eff = net.effective()
    c0, w, alpha, beta, beta0 = (t.detach().numpy() for t in eff)
    mse, *grads = nlarx_grad.one_step_loss_grad(
        float(c0), w, alpha, np.ascontiguousarray(beta), beta0, phi.numpy(), target.numpy(), net.out_scale)
    grads[0] = grads[0].reshape(())
    pairs = [(t, torch.from_numpy(g)) for t, g in zip(eff, grads, strict=True) if t.requires_grad]
    decay = weight_decay * (net.beta.square().sum() + net.alpha.square().sum())
    torch.autograd.backward([decay] + [t for t, _ in pairs], [None] + [g for _, g in pairs])
    return decay.detach() + mse


def _simulation_stage(
    net: NlarxNet,
    experiments: tuple[Experiment, ...],
    smooth: tuple[Experiment, ...],
    xs: float,
    us: float,
    stroke: float,
    cfg: NlarxConfig,
) -> None:
    """Adam on the mean squared free-run error of batched truncated rollouts.

    Targets are the measured positions (their noise averages out in the
    mean square); each rollout starts from the *smoothed* positions, since a
    start from two raw samples carries a velocity error of sqrt(2) σ / dt.
    """
    x = torch.from_numpy(np.concatenate([e.y for e in experiments]) / xs)
    xf = torch.from_numpy(np.concatenate([e.y for e in smooth]) / xs)
    u = torch.from_numpy(np.concatenate([e.u for e in experiments]) / us)
    horizon = min(cfg.horizon, min(len(e) for e in experiments) - 2)
    starts = _window_starts(experiments, horizon)
    lim = 0.5 * stroke / xs
    gen = torch.Generator().manual_seed(cfg.seed + 1)
    opt = torch.optim.Adam([p for p in net.parameters() if p.requires_grad], lr=cfg.lr)
    steps = torch.arange(horizon)
    for _ in range(cfg.sim_iters):
        st = starts[torch.randint(len(starts), (cfg.batch,), generator=gen)]
        opt.zero_grad()
        if cfg.numerics == "compiled":
            _compiled_backward(net, x, xf, u, st, horizon, lim)
        else:
            idx = st[:, None] + steps[None, :]
            pred = _rollout(net, xf[st], xf[st - 1], u[idx], u[st - 1], lim)
            torch.mean((pred - x[idx + 1]).square()).backward()
        opt.step()


def _compiled_backward(
    net: NlarxNet, x: torch.Tensor, xf: torch.Tensor, u: torch.Tensor, st: torch.Tensor,
    horizon: int, lim: float,
) -> None:
    """Accumulate the rollout loss's gradient in ``net``'s parameters (as ``loss.backward()`` would).

    The compiled rollout gives the gradient by the effective weights; torch
    carries it through :meth:`NlarxNet.effective` onto the parameters.
    """
    eff = net.effective()
    c0, w, alpha, beta, beta0 = (t.detach().numpy() for t in eff)
    _, *grads = nlarx_grad.rollout_loss_grad(
        float(c0), w, alpha, np.ascontiguousarray(beta), beta0,
        x.numpy(), xf.numpy(), u.numpy(), st.numpy(), horizon, lim,
    )
    grads[0] = grads[0].reshape(())
    torch.autograd.backward(eff, [torch.from_numpy(g) for g in grads])


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


def _train_fit(
    params: FloatArray, experiments: tuple[Experiment, ...], smooth: tuple[Experiment, ...]
) -> float:
    """Free-run fit on the training record from the smoothed first samples (the stage guard)."""
    ys, yh = [], []
    for e, f in zip(experiments, smooth, strict=True):
        state = np.array([f.y[1], f.y[0], e.u[0], 0.0])
        # the record holds the forces that acted, so no further limit applies
        sim = kernels.rollout(kernels.Kernel(kernels.KIND_NLARX, params, np.inf), e.u[1:], state)
        ys.append(e.y)
        yh.append(np.concatenate([f.y[:1], sim]))
    return fit_percent(np.concatenate(ys), np.concatenate(yh))
