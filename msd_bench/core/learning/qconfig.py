"""Configuration of the tabular Q-learning agent (paper §4) and its packed form.

:class:`QConfig` holds every choice of the paper's learner, with the values the
paper prints (or, where it prints none, the ones docs/decisions.md §Reward found to behave).
:func:`packed` turns a config into a :class:`Learner` — named tuples of scalars
and arrays, which numba compiles against by type, not by value — so one
compiled kernel of :mod:`msd_bench.core.learning.q_kernels` serves every config and the
kernels read ``learner.alpha``, not a hand-numbered slot.

Two state encoders:

* ``"paper"`` — 100 uniform bins of the clipped error (eq. 18), 0-based
  ``s = floor(99 (ẽ + 5) / 10 + 0.5)`` (round half up), so e = -5 → 0,
  e = 0 → 50, e = +5 → 99; zero error sits on the edge between bins 49 and 50.
* ``"improved"`` — **our extension, not the paper's**: a non-uniform grid,
  fine near zero, of the *lead error* ``e_k + lead_steps (x_k - x_{k-1})``
  (error plus its predicted change over ``lead_steps`` samples), optionally
  times the sign of the last position change and a coarse reference bin. The
  paper's state cannot tell an approach from a retreat and its 0.1 m bins park
  the mass at a bin edge, so which action wins just below the target is a coin
  flip across seeds (docs/decisions.md §Distributions). Switching on the lead error is a sliding
  surface: the sign of the right action follows from the bin alone. Use
  :func:`improved_config`, which also lowers α to 0.1 so each cell averages
  over more of its aliased transitions. On the true plant (64 seeds) the
  separate direction bit and the reference bin both made things *worse*: more
  cells, fewer visits per cell in the paper's 900 k-step budget.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]

MODE_PAPER = 0
MODE_IMPROVED = 1
STATE_MODES = {"paper": MODE_PAPER, "improved": MODE_IMPROVED}
SHAPINGS = ("away", "toward")
OBSERVERS = ("none", "alpha-beta", "model")
OBS_NONE, OBS_ALPHA_BETA, OBS_MODEL = 0, 1, 2
MAX_DELAY_SAMPLES = 10
"""The longest actuator delay (samples) a model observer assumes (``obs_delay``) or training draws
(``train_delay``)."""
N_ACTIONS = 5
N_DIRECTIONS = 3


@dataclass(frozen=True)
class QConfig:
    """Everything the Q-learning agent of paper §4 needs (defaults = the paper's)."""

    episodes: int = 300
    """Training episodes N_ep (paper: 300); each starts from rest."""
    steps: int = 3000
    """Decision steps per episode T (paper: 3,000 at 0.01 s = 30 s)."""
    alpha: float = 0.5
    """Learning rate α in (0, 1] (paper: 0.5)."""
    gamma: float = 0.9
    """Discount γ in [0, 1) (paper: 0.9)."""
    epsilon: float = 0.1
    """ε-greedy exploration probability in [0, 1] (paper: 0.1); greedy ties are broken at random."""
    reward_gain: float = 1.0
    """Reward amplification A > 0 (paper: 'A > 0', value not given; 1)."""
    g: float = 1.0
    """Weight g > 0 of the closeness term g/(1+E) (not given; 1, docs/decisions.md §Reward)."""
    zeta: float = 10.0
    """Weight ζ >= 0 of the error-change term ζ ΔE/E_max (not given; 0..50 behaved alike)."""
    e_max: float = 5.0
    """Error clip and reward normalisation e_max = E_max (paper: 5, the ±2.5 m stroke)."""
    eta: float = 0.05
    """Weight η >= 0 of the shaping *penalty* for actions pushing away from the target.

    The paper prints ``+ η φ(s,a)`` with φ >= 0 yet calls it a penalty; as
    printed it is a bonus. We subtract it, which is what the text means. Which
    actions count as pushing away matters more than η (docs/decisions.md §Shaping). 0 disables it."""
    force: float = 10.0
    """Force magnitude F in N: actions are {-F, -F/2, 0, F/2, F} (paper: 10)."""
    target_low: float = -2.0
    """Lower end of the uniform training-target draw, m.

    The paper draws targets 'within the admissible range' without numbers;
    ±2 m is what the ±F alphabet can hold on our plant (docs/design.md §Plant), so every
    drawn target is reachable and the unit validation step lies inside."""
    target_high: float = 2.0
    """Upper end of the uniform training-target draw, m (> target_low, or equal for a fixed target)."""
    n_states: int = 100
    """Bins of the paper's uniform error grid (paper: 100); ignored by the improved encoder."""
    snapshot_episodes: tuple[int, ...] = (1,)
    """Episode counts (1-based) after which the Q-table is copied for heat maps.

    The first and the last episode are always included; counts beyond
    ``episodes`` are ignored, so a shortened run needs no edit here."""
    state: str = "paper"
    """State encoder: ``"paper"`` (eq. 18) or ``"improved"`` (our extension, see module doc)."""
    error_edges: tuple[float, ...] = (0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.25, 0.5, 1.0, 2.0)
    """Improved encoder: increasing positive |e| bin edges in m, mirrored about 0 (0 is an edge)."""
    lead_steps: float = 50.0
    """Improved encoder: bin e + lead_steps (x_k - x_{k-1}), a phase lead of lead_steps samples."""
    direction_bins: bool = False
    """Improved encoder: also split by the sign of x_k - x_{k-1} (falling / still / rising)."""
    direction_tol: float = 1e-5
    """Improved encoder: |x_k - x_{k-1}| at or below this (m) counts as 'still'."""
    reference_edges: tuple[float, ...] = ()
    """Improved encoder: increasing edges (m) of a coarse reference bin; () = no reference bin."""
    shaping: str = "away"
    """Which actions the shaping penalty φ marks (docs/decisions.md §Shaping): ``"away"`` — a force
    that pushes away from the target, outside the zero-error bins; ``"toward"`` — every action that
    does not push toward the target, u = 0 included, in every bin."""
    observer: str = "none"
    """How the agent estimates position and velocity from measurements (our robust agent):
    ``none`` — raw samples and their last difference (paper and improved agents); ``alpha-beta`` — an
    α-β tracker; ``model`` — the model it trains on run as a predictor, corrected by the innovation."""
    obs_gain: float = 0.0
    """Observer: position gain on the innovation (measured minus predicted position), in (0, 1]."""
    obs_velocity_gain: float = 0.0
    """Observer: velocity gain on the innovation (α-β: per-sample displacement; model: per dt)."""
    obs_velocity_share: float = 1.0
    """Model observer: the share of the position correction L·r that also moves the velocity estimate.
    1 moves the estimate as a whole (an ARX model's implied displacement follows its position): the
    observer's error then rings at about sqrt(L) rad per sample. Near 2 (1 - sqrt(1 - L)) / L - 1 it is
    critically damped, and the velocity, which the lead multiplies by 50, takes in less noise."""
    obs_drift_gain: float = 0.0
    """Model observer: gain of its integral correction — a per-sample position drift, estimated from the
    innovation and added to every prediction, so a surrogate that drifts where the plant holds still
    (a wrong equilibrium force) leaves no steady bias of about (1 - L)/L times that drift."""
    obs_delay: int = 0
    """Model observer: predict with the force commanded ``obs_delay`` samples ago — the actuator delay the
    observer assumes. A real actuator's delay is unknown; assuming the middle of a range halves the worst
    mismatch (docs/decisions.md §Robust)."""
    obs_bias_gain: float = 0.0
    """Model observer: gain (N per m of innovation) of its force-bias state — an estimate of a constant
    force the model does not know (a load, a wrong equilibrium force), added to the force the predictor
    is driven with and updated from the innovation each sample: the observer's integral action. 0 = off.
    In the double-integrator approximation (dt²/m = 1e-4 m/N per sample) its error dynamics are stable
    up to a gain of about 13 at L = 0.05 and share 0.5 (fastest near 4.5; share 0.2: up to 5), up to
    about 55 at L = 0.1 and share 0.5 (fastest near 17)."""
    train_noise: float = 0.0
    """Training on the surrogate: each episode draws a sensor noise σ uniformly in [0, train_noise] m."""
    train_delay: int = 0
    """Training on the surrogate: each episode draws an actuator delay in {0, …, train_delay} samples."""
    length_unit: float = 1.0
    """Metres of the rig per paper metre (:attr:`Scales.length`): the reward's closeness term g/(1+E) counts
    E in paper metres, E / length_unit, so it rewards the same fraction of the stroke on every rig
    (docs/decisions.md §Scales). Set by :meth:`QConfig.scaled`; exactly 1.0 on the paper's plant."""
    force_unit: float = 1.0
    """Newtons of the rig per paper newton (:attr:`Scales.force`): the bounds on ``obs_bias_gain`` are
    checked in paper units. Set by :meth:`QConfig.scaled`; exactly 1.0 on the paper's plant."""
    sample_unit: float = 1.0
    """Rig samples per paper sample (:meth:`Scales.steps` of 1): a rehearsal's SSE window, stated in
    paper samples, lasts the same on the rig. Set by :meth:`QConfig.scaled`; exactly 1.0 on the paper's
    plant."""
    obs_bias_feedforward: bool = False
    """Model observer: command the chosen force less the force-bias estimate (disturbance-observer
    compensation), in training and when acting. Why: on a rig held by a stiff position loop a force the
    surrogate does not know (Coulomb friction, an offset) stalls the stage short of the set-point by that
    force over the loop's stiffness, while the table, learnt on a surrogate without it, keeps choosing the
    force that creeps there on the surrogate; the observer's bias state measures the missing force, so
    taking it back out gives the table the plant it learnt on (docs/rigs.md §The robust agent on a held
    rig). Off (bit for bit the agent before) unless the rig states a hold loop
    (:func:`msd_bench.designs.qlearning.for_drive`)."""
    hold_stiffness: float = 0.0
    """The stiffness of the position loop the rig's drive adds to every command, N/m (a stage's stated
    hold loop, docs/rig-families.md §stage; 0: a bare rig). The command then carries the loop's force at
    the set-point, ``hold_stiffness (target - hold_position)``, beside the chosen force, in training and
    when acting, so the loop holds the set-point instead of its own position. Why: the surrogate is of
    the held system, whose rest position under a constant force depends on the set-point; one table, no
    reference bin, cannot learn the set-point's holding force for every target (on design stages the
    NLARX robust table parks at a bin edge short of the set-point on its own surrogate); with the loop's
    force carried, zero force holds every set-point and the table only corrects
    (:func:`msd_bench.designs.qlearning.for_drive`)."""
    hold_position: float = 0.0
    """The position the rig's stated hold loop holds, m (with ``hold_stiffness``)."""
    select_every: int = 0
    """Keep, instead of the final table, the best of the tables taken every ``select_every`` episodes over
    the second half of training, judged by greedy rehearsals on the model trained on
    (:mod:`msd_bench.core.learning.selection`; docs/decisions.md §Robust, round 5). 0 = the final table."""

    def __post_init__(self) -> None:
        _require(self.episodes >= 1 and self.steps >= 1, "episodes and steps must be >= 1")
        _require(0.0 < self.alpha <= 1.0, f"alpha must be in (0, 1], got {self.alpha}")
        _require(0.0 <= self.gamma < 1.0, f"gamma must be in [0, 1), got {self.gamma}")
        _require(0.0 <= self.epsilon <= 1.0, f"epsilon must be in [0, 1], got {self.epsilon}")
        for name in ("reward_gain", "g", "e_max", "force", "length_unit", "force_unit", "sample_unit"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value > 0, f"{name} must be finite and > 0")
        for name in ("zeta", "eta", "direction_tol", "lead_steps"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value >= 0, f"{name} must be finite and >= 0")
        _require(math.isfinite(self.target_low) and math.isfinite(self.target_high)
                 and self.target_low <= self.target_high, "need finite target_low <= target_high")
        _require(self.n_states >= 3, f"n_states must be >= 3, got {self.n_states}")
        _require(self.state in STATE_MODES, f"state must be one of {sorted(STATE_MODES)}")
        _require(all(e >= 1 for e in self.snapshot_episodes), "snapshot_episodes must be >= 1")
        _require(_increasing(self.error_edges) and len(self.error_edges) > 0
                 and self.error_edges[0] > 0, "error_edges must be positive and increasing")
        _require(_increasing(self.reference_edges), "reference_edges must be increasing")
        _require(self.shaping in SHAPINGS, f"shaping must be one of {SHAPINGS}, got {self.shaping!r}")
        _require(self.observer in OBSERVERS, f"observer must be one of {OBSERVERS}, got {self.observer!r}")
        _require((self.observer == "none") == (self.obs_gain == 0.0) and 0.0 <= self.obs_gain <= 1.0
                 and 0.0 <= self.obs_velocity_gain <= 1.0,
                 "an observer needs a gain in (0, 1] (and none without one); velocity gain in [0, 1]")
        _require(math.isfinite(self.train_noise) and 0.0 <= self.train_noise / self.length_unit <= 0.1,
                 "train_noise must be in [0, 0.1] m on the paper's plant (x length_unit on a rig)")
        _require(0 <= self.train_delay <= MAX_DELAY_SAMPLES,
                 f"train_delay must be in 0..{MAX_DELAY_SAMPLES} samples")
        _require(0 <= self.select_every <= 100_000, "select_every must be in 0..100000 episodes")
        _require(0.0 <= self.obs_velocity_share <= 1.0
                 and (self.obs_velocity_share == 1.0 or self.observer == "model"),
                 "obs_velocity_share must be in [0, 1], and only a model observer has one")
        _require(0.0 <= self.obs_drift_gain <= 1.0
                 and (self.obs_drift_gain == 0.0 or self.observer == "model"),
                 "obs_drift_gain must be in [0, 1], and only a model observer has one")
        _require(math.isfinite(self.obs_bias_gain)
                 and 0.0 <= self.obs_bias_gain * self.length_unit / self.force_unit <= 1000.0
                 and (self.obs_bias_gain == 0.0 or self.observer == "model"),
                 "obs_bias_gain must be in [0, 1000] N/m on the paper's plant (x force_unit / length_unit "
                 "on a rig), and only a model observer has one")
        _require(0 <= self.obs_delay <= MAX_DELAY_SAMPLES
                 and (self.obs_delay == 0 or self.observer == "model"),
                 f"obs_delay must be in 0..{MAX_DELAY_SAMPLES} samples, and only a model observer "
                 "assumes one")
        _require(math.isfinite(self.hold_stiffness) and self.hold_stiffness >= 0.0
                 and math.isfinite(self.hold_position),
                 "hold_stiffness must be finite and >= 0, hold_position finite")
        _require(not self.obs_bias_feedforward or self.obs_bias_gain > 0.0,
                 "obs_bias_feedforward needs a force-bias state (obs_bias_gain > 0)")
        _require(self.state != "paper" or not self.observed,
                 "the observer and training perturbations need the improved state")

    @property
    def observed(self) -> bool:
        """Whether the learner sees the plant through an observer or trains under perturbations."""
        return self.observer != "none" or self.train_noise > 0.0 or self.train_delay > 0

    def snapshots(self) -> tuple[int, ...]:
        """Sorted episode counts at which a snapshot is taken (first, last and selection candidates)."""
        keep = {1, self.episodes} | {e for e in self.snapshot_episodes if e <= self.episodes}
        return tuple(sorted(keep | set(self.selection_episodes())))

    def selection_episodes(self) -> tuple[int, ...]:
        """Episode counts whose tables compete for the one kept (``select_every``), latest first.

        Counted back from the final episode over the second half of training, so a
        shortened run still selects among its own late tables; () when selection is off.
        """
        if self.select_every == 0:
            return ()
        return tuple(range(self.episodes, self.episodes // 2 - 1, -self.select_every))

    def scaled(self, scales: Scales) -> QConfig:
        """This config, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md §Scales).

        Lengths (error clip, error edges, training targets, the still tolerance per sample)
        scale with the stroke, the force alphabet with the force limit; durations stay in
        seconds: the episode and the lead horizon become ``scales.samples`` of their paper
        counts. Every factor is 1.0 on the paper's plant, so there the config is unchanged, bit
        for bit. Delays (``obs_delay``, ``train_delay``) are in rig samples already and are kept.
        """
        if scales.is_default:
            return self
        m = scales.metres
        return replace(
            self, e_max=m(self.e_max), error_edges=tuple(m(e) for e in self.error_edges),
            reference_edges=tuple(m(e) for e in self.reference_edges),
            target_low=m(self.target_low), target_high=m(self.target_high),
            direction_tol=scales.per_sample(m(self.direction_tol)), force=scales.newtons(self.force),
            steps=scales.samples(self.steps), lead_steps=scales.steps(self.lead_steps),
            train_noise=m(self.train_noise), obs_bias_gain=scales.newtons(self.obs_bias_gain) / scales.length,
            length_unit=self.length_unit * scales.length, force_unit=self.force_unit * scales.force,
            sample_unit=self.sample_unit * scales.steps(1.0))

    def actions(self) -> FloatArray:
        """The force alphabet {-F, -F/2, 0, F/2, F} in N."""
        f = self.force
        return np.array([-f, -f / 2, 0.0, f / 2, f])


def improved_config(scales: Scales = Scales.DEFAULT, /, **overrides: object) -> QConfig:
    """Our improved agent (not the paper's): lead-error grid and α = 0.1; fields overridable (in paper
    units), the whole on a rig of ``scales``."""
    fields: dict[str, object] = {"state": "improved", "alpha": 0.1}
    fields.update(overrides)
    return QConfig(**fields).scaled(scales)  # type: ignore[arg-type]


class Encoding(NamedTuple):
    """The state encoder of a config, as the compiled :func:`qlearning.encode` reads it."""

    mode: int
    """``MODE_PAPER`` or ``MODE_IMPROVED``."""
    n_states: int
    """Rows of the Q-table."""
    e_max: float
    """Paper grid: errors are clipped to ±e_max before binning."""
    lead_steps: float
    """Improved: the binned quantity is e + lead_steps · (x_k - x_{k-1})."""
    n_directions: int
    """Improved: 3 with direction bins (falling / still / rising), else 1."""
    direction_tol: float
    """Improved: |x_k - x_{k-1}| at or below this counts as still, m."""
    err_edges: FloatArray
    """Improved: full mirrored error edges (empty for the paper grid)."""
    ref_edges: FloatArray
    """Improved: reference edges (may be empty)."""


class Learner(NamedTuple):
    """Everything the compiled learner reads: encoder, update and reward weights, φ, forces."""

    enc: Encoding
    """The state encoder."""
    alpha: float
    """Learning rate α."""
    gamma: float
    """Discount γ."""
    epsilon: float
    """ε-greedy exploration probability."""
    reward_gain: float
    """Reward amplification A."""
    g: float
    """Weight of the closeness term g/(1+E)."""
    zeta: float
    """Weight of the error-change term ζ ΔE/E_max."""
    e_max: float
    """Reward normalisation E_max, m."""
    eta: float
    """Weight of the shaping penalty η φ(s, a)."""
    target_low: float
    """Lower end of the episode-target draw, m."""
    target_high: float
    """Upper end of the episode-target draw, m."""
    phi: FloatArray
    """Shaping indicator φ(s, a) in {0, 1}, shape (n_states, 5)."""
    actions: FloatArray
    """Force per action index, N."""
    observed: bool
    """Whether :func:`qlearning.learn_observed` trains it (observer and/or training perturbations)."""
    observer: int
    """``OBS_NONE``, ``OBS_ALPHA_BETA`` or ``OBS_MODEL``."""
    obs_gain: float
    """Observer position gain on the innovation."""
    obs_velocity_gain: float
    """α-β tracker velocity gain."""
    train_noise: float
    """Largest sensor noise σ drawn per training episode, m."""
    train_delay: int
    """Largest actuator delay drawn per training episode, samples."""
    obs_velocity_share: float
    """Model observer: share of the position correction that also moves the velocity."""
    obs_drift_gain: float
    """Model observer's integral gain on the innovation (a per-sample drift estimate)."""
    obs_delay: int
    """Actuator delay the model observer assumes, samples."""
    obs_bias_gain: float
    """Model observer's gain on its force-bias state, N per m of innovation (0 = no bias state)."""
    length_unit: float
    """Rig metres per paper metre: the closeness term counts E / length_unit."""
    obs_bias_feedforward: bool
    """Model observer: command the chosen force less the force-bias estimate."""
    hold_stiffness: float
    """The rig's stated hold loop's stiffness, N/m: the command carries its force at the set-point."""
    hold_position: float
    """The position the stated hold loop holds, m."""


def encoding(cfg: QConfig) -> Encoding:
    """The state encoder of ``cfg``."""
    n_dir = N_DIRECTIONS if cfg.direction_bins else 1
    if cfg.state == "paper":
        return Encoding(MODE_PAPER, cfg.n_states, cfg.e_max, cfg.lead_steps, n_dir,
                        cfg.direction_tol, np.zeros(0), np.zeros(0))
    pos = np.asarray(cfg.error_edges, dtype=np.float64)
    edges = np.concatenate([-pos[::-1], [0.0], pos])
    ref = np.asarray(cfg.reference_edges, dtype=np.float64)
    n_states = (edges.size + 1) * n_dir * (ref.size + 1)
    return Encoding(MODE_IMPROVED, n_states, cfg.e_max, cfg.lead_steps, n_dir, cfg.direction_tol,
                    edges, ref)


def packed(cfg: QConfig) -> Learner:
    """``cfg`` as the compiled kernels take it, including the φ table of its encoder."""
    enc = encoding(cfg)
    actions = cfg.actions()
    return Learner(enc, cfg.alpha, cfg.gamma, cfg.epsilon, cfg.reward_gain, cfg.g, cfg.zeta,
                   cfg.e_max, cfg.eta, cfg.target_low, cfg.target_high,
                   _phi_table(_error_side(cfg, enc), actions, cfg.shaping), actions, cfg.observed,
                   OBSERVERS.index(cfg.observer), cfg.obs_gain, cfg.obs_velocity_gain, cfg.train_noise,
                   cfg.train_delay, cfg.obs_velocity_share,
                   cfg.obs_drift_gain, cfg.obs_delay, cfg.obs_bias_gain, cfg.length_unit,
                   cfg.obs_bias_feedforward, cfg.hold_stiffness, cfg.hold_position)


def _error_side(cfg: QConfig, enc: Encoding) -> NDArray[np.int64]:
    """Per state: -1 below the target, +1 above; 0 in the zero-error bins for the ``away`` reading.

    The ``toward`` reading marks actions in every bin, the zero bins too, so
    there each zero bin takes the side of its centre.
    """
    width = 2 if cfg.shaping == "away" else 1
    if enc.mode == MODE_PAPER:
        n = cfg.n_states
        # Bin i has centre -e_max + i * step; it is a zero bin when |centre| < step.
        return np.array([_side(2 * i - (n - 1), width) for i in range(n)], dtype=np.int64)
    n_err = enc.err_edges.size + 1
    zero = len(cfg.error_edges) + 1  # bins zero-1 = [-e1, 0) and zero = [0, e1) touch zero error
    err_side = np.array([_side(2 * i - (2 * zero - 1), width) for i in range(n_err)], dtype=np.int64)
    return np.repeat(err_side, enc.n_directions * (enc.ref_edges.size + 1))


def _side(twice_offset: int, width: int) -> int:
    """-1 below the zero-error bins, 0 inside them, +1 above (integer, exact)."""
    if abs(twice_offset) < width:
        return 0
    return 1 if twice_offset > 0 else -1


def _phi_table(side: NDArray[np.int64], actions: FloatArray, shaping: str = "away") -> FloatArray:
    """φ(s, a) = 1 where the action is penalised, else 0.

    ``away``: the force has the sign of the error (e = x - target), i.e. pushes
    away from the target. ``toward``: the force does not push toward the target
    (its sign is not opposite to the error's): zero force included.
    """
    push = side[:, None] * np.sign(actions)[None, :]
    return (push > 0 if shaping == "away" else push >= 0).astype(float)


def _increasing(values: tuple[float, ...]) -> bool:
    return all(math.isfinite(v) for v in values) and all(
        a < b for a, b in itertools.pairwise(values))


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ConfigError(message)
