"""Configuration of the tabular Q-learning agent (paper §4) and its packed form.

:class:`QConfig` holds every choice of the paper's learner, with the values the
paper prints (or, where it prints none, the ones docs/decisions.md §Reward found to behave).
:func:`encoding` packs a config into plain arrays for the compiled kernels of
:mod:`msd_bench.core.qlearning`, so a config never crosses into numba as an
object and one compiled kernel serves every config.

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
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError

FloatArray = NDArray[np.float64]

MODE_PAPER = 0
MODE_IMPROVED = 1
STATE_MODES = {"paper": MODE_PAPER, "improved": MODE_IMPROVED}
N_ACTIONS = 5
N_DIRECTIONS = 3

# Layout of the packed hyper-parameter vector read by the kernels.
HP_ALPHA, HP_GAMMA, HP_EPS, HP_GAIN, HP_G, HP_ZETA = 0, 1, 2, 3, 4, 5
HP_EMAX, HP_ETA, HP_TLOW, HP_THIGH, HP_DIRTOL, HP_LEAD, HP_NDIR = 6, 7, 8, 9, 10, 11, 12
HP_SIZE = 13


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

    def __post_init__(self) -> None:
        _require(self.episodes >= 1 and self.steps >= 1, "episodes and steps must be >= 1")
        _require(0.0 < self.alpha <= 1.0, f"alpha must be in (0, 1], got {self.alpha}")
        _require(0.0 <= self.gamma < 1.0, f"gamma must be in [0, 1), got {self.gamma}")
        _require(0.0 <= self.epsilon <= 1.0, f"epsilon must be in [0, 1], got {self.epsilon}")
        for name in ("reward_gain", "g", "e_max", "force"):
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

    def snapshots(self) -> tuple[int, ...]:
        """Sorted episode counts at which a snapshot is taken (first and last included)."""
        keep = {1, self.episodes} | {e for e in self.snapshot_episodes if e <= self.episodes}
        return tuple(sorted(keep))

    def actions(self) -> FloatArray:
        """The force alphabet {-F, -F/2, 0, F/2, F} in N."""
        f = self.force
        return np.array([-f, -f / 2, 0.0, f / 2, f])


def improved_config(**overrides: object) -> QConfig:
    """Our improved agent (not the paper's): lead-error grid and α = 0.1; fields overridable."""
    fields: dict[str, object] = {"state": "improved", "alpha": 0.1}
    fields.update(overrides)
    return QConfig(**fields)  # type: ignore[arg-type]


class Encoding(NamedTuple):
    """A config packed into arrays for the compiled kernels."""

    mode: int
    """``MODE_PAPER`` or ``MODE_IMPROVED``."""
    n_states: int
    """Rows of the Q-table."""
    hp: FloatArray
    """Hyper-parameters in the ``HP_*`` layout."""
    err_edges: FloatArray
    """Improved encoder: full mirrored error edges (empty for the paper grid)."""
    ref_edges: FloatArray
    """Improved encoder: reference edges (may be empty)."""
    phi: FloatArray
    """Shaping indicator φ(s, a) in {0, 1}, shape (n_states, 5)."""
    actions: FloatArray
    """Force per action index, N."""


def encoding(cfg: QConfig) -> Encoding:
    """Pack ``cfg`` for the kernels, including the φ table of the chosen encoder."""
    hp = np.zeros(HP_SIZE)
    hp[[HP_ALPHA, HP_GAMMA, HP_EPS, HP_GAIN, HP_G, HP_ZETA]] = (
        cfg.alpha, cfg.gamma, cfg.epsilon, cfg.reward_gain, cfg.g, cfg.zeta)
    n_dir = N_DIRECTIONS if cfg.direction_bins else 1
    hp[[HP_EMAX, HP_ETA, HP_TLOW, HP_THIGH, HP_DIRTOL, HP_LEAD, HP_NDIR]] = (
        cfg.e_max, cfg.eta, cfg.target_low, cfg.target_high, cfg.direction_tol, cfg.lead_steps,
        n_dir)
    actions = cfg.actions()
    if cfg.state == "paper":
        n = cfg.n_states
        # Bin i has centre -e_max + i * step; it is a zero bin when |centre| < step.
        side = np.array([_side(2 * i - (n - 1), 2) for i in range(n)])
        phi = _phi_table(side, actions)
        return Encoding(MODE_PAPER, n, hp, np.zeros(0), np.zeros(0), phi, actions)
    pos = np.asarray(cfg.error_edges, dtype=float)
    edges = np.concatenate([-pos[::-1], [0.0], pos])
    n_err = edges.size + 1
    zero = pos.size + 1  # bins zero-1 = [-e1, 0) and zero = [0, e1) touch zero error
    err_side = np.array([_side(2 * i - (2 * zero - 1), 2) for i in range(n_err)])
    ref = np.asarray(cfg.reference_edges, dtype=float)
    per_bin = n_dir * (ref.size + 1)
    side = np.repeat(err_side, per_bin)
    return Encoding(MODE_IMPROVED, n_err * per_bin, hp, edges, ref, _phi_table(side, actions),
                    actions)


def _side(twice_offset: int, width: int) -> int:
    """-1 below the zero-error bins, 0 inside them, +1 above (integer, exact)."""
    if abs(twice_offset) < width:
        return 0
    return 1 if twice_offset > 0 else -1


def _phi_table(side: NDArray[np.int64], actions: FloatArray) -> FloatArray:
    """φ(s, a) = 1 where the force has the sign of the error (pushes away), else 0."""
    return (side[:, None] * np.sign(actions)[None, :] > 0).astype(float)


def _increasing(values: tuple[float, ...]) -> bool:
    return all(math.isfinite(v) for v in values) and all(
        a < b for a, b in itertools.pairwise(values))


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ConfigError(message)
