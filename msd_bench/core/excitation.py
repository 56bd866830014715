"""Seeded excitation signals of the paper's experiments (§3.2, §3.3).

* :func:`prbs` — a maximum-length pseudo-random binary sequence of ±amplitude
  around a bias (the PLM's five operating-point experiments);
* :func:`multilevel` — pseudo-random switching over the action alphabet with
  minimum/maximum dwell (the NLARX and GLM record);
* :func:`steps` — a staircase of constant levels.

Every generator is a pure function of its config and seed and returns one
force per sample; the same seed always gives the same signal.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError

FloatArray = NDArray[np.float64]

# Feedback taps of maximum-length Fibonacci LFSRs (Xilinx XAPP052).
_LFSR_TAPS = {7: (7, 6), 9: (9, 5), 10: (10, 7), 11: (11, 9), 15: (15, 14)}


@dataclass(frozen=True)
class PrbsConfig:
    """PRBS of ±amplitude around a bias (PLM experiments, paper §3.2)."""

    bias: float = 0.0
    """Constant force the PRBS toggles around, N (paper: one of -10, -5, 0, 5, 10)."""
    amplitude: float = 1.0
    """Half the peak-to-peak toggle, N (paper: ±1 N)."""
    n_samples: int = 12_000
    """Samples of the identification record (paper: 12,000 at 0.01 s)."""
    hold: int = 20
    """Samples each PRBS bit is held (clock period); 20 × 0.01 s excites up to ~2.5 Hz."""
    register_bits: int = 10
    """LFSR length; the sequence repeats after (2^bits - 1) × hold samples."""
    settle: int = 1_000
    """Samples of constant bias before the PRBS, so the record starts near the operating point."""

    def __post_init__(self) -> None:
        _require(self.amplitude > 0, "amplitude must be > 0")
        _require(self.n_samples > 0, "n_samples must be > 0")
        _require(self.hold >= 1, "hold must be >= 1")
        _require(self.settle >= 0, "settle must be >= 0")
        _require(self.register_bits in _LFSR_TAPS, f"register_bits must be one of {sorted(_LFSR_TAPS)}")


@dataclass(frozen=True)
class MultilevelConfig:
    """Pseudo-random switching over a force alphabet with dwell limits (paper §3.3)."""

    levels: tuple[float, ...] = (-10.0, -5.0, 0.0, 5.0, 10.0)
    """Forces to switch among, N (paper: the action alphabet with F = 10 N)."""
    n_samples: int = 12_000
    """Samples of the record (paper: 12,000)."""
    min_dwell: int = 30
    """Shortest time a level is held, samples."""
    max_dwell: int = 300
    """Longest time a level is held, samples."""

    def __post_init__(self) -> None:
        _require(len(self.levels) >= 2, "levels needs at least two forces")
        _require(self.n_samples > 0, "n_samples must be > 0")
        _require(1 <= self.min_dwell <= self.max_dwell, "need 1 <= min_dwell <= max_dwell")


@dataclass(frozen=True)
class StepsConfig:
    """A staircase: each level held for ``dwell`` samples."""

    levels: tuple[float, ...] = field(default=(0.0, 5.0, 0.0, -5.0))
    """Forces in order, N."""
    dwell: int = 1_000
    """Samples per level."""

    def __post_init__(self) -> None:
        _require(len(self.levels) >= 1, "levels needs at least one force")
        _require(self.dwell >= 1, "dwell must be >= 1")


def prbs_bits(n_bits: int, register_bits: int, seed: int) -> NDArray[np.int8]:
    """``n_bits`` values in {-1, +1} from a maximum-length LFSR started at a seeded state."""
    a, b = _LFSR_TAPS[register_bits]
    period = (1 << register_bits) - 1
    state = 1 + (seed % period)  # never the all-zero lock-up state
    out = np.empty(n_bits, dtype=np.int8)
    for i in range(n_bits):
        bit = ((state >> (a - 1)) ^ (state >> (b - 1))) & 1
        state = ((state << 1) | bit) & period
        out[i] = 1 if bit else -1
    return out


def prbs(cfg: PrbsConfig, seed: int) -> FloatArray:
    """Settling segment at the bias, then ``n_samples`` of bias ± amplitude PRBS."""
    n_bits = -(-cfg.n_samples // cfg.hold)
    bits = np.repeat(prbs_bits(n_bits, cfg.register_bits, seed), cfg.hold)[: cfg.n_samples]
    toggled = cfg.bias + cfg.amplitude * bits.astype(float)
    return np.concatenate([np.full(cfg.settle, float(cfg.bias)), toggled])


def multilevel(cfg: MultilevelConfig, seed: int) -> FloatArray:
    """Levels drawn uniformly (never the same twice in a row), dwell uniform in the limits."""
    rng = np.random.default_rng(seed)
    levels = np.asarray(cfg.levels, dtype=float)
    out = np.empty(cfg.n_samples)
    k, last = 0, -1
    while k < cfg.n_samples:
        choice = int(rng.integers(len(levels) - 1)) if last >= 0 else int(rng.integers(len(levels)))
        if last >= 0 and choice >= last:
            choice += 1
        dwell = int(rng.integers(cfg.min_dwell, cfg.max_dwell + 1))
        out[k : k + dwell] = levels[choice]
        k, last = k + dwell, choice
    return out


def steps(cfg: StepsConfig) -> FloatArray:
    """The staircase of ``cfg.levels``, each held ``cfg.dwell`` samples."""
    return np.repeat(np.asarray(cfg.levels, dtype=float), cfg.dwell)


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ConfigError(message)


_CONFIGS: dict[str, type] = {"prbs": PrbsConfig, "multilevel": MultilevelConfig, "steps": StepsConfig}


def signal_from_params(params: dict[str, object]) -> FloatArray | None:
    """Regenerate a played signal from the parameters a bag stores; None if it stores none.

    A bag written by our recorder says which generator played (``signal``), its
    config (under the signal's name) and its ``seed``, so the exact command
    sequence can be rebuilt — e.g. to find where a real-time recording started.
    """
    kind = params.get("signal")
    raw = params.get(str(kind))
    if kind not in _CONFIGS or not isinstance(raw, dict):
        return None
    fields = {k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()}
    try:
        cfg = _CONFIGS[str(kind)](**fields)
    except TypeError as exc:
        raise ConfigError(f"bag parameters do not describe a {kind} signal: {exc}") from None
    if isinstance(cfg, PrbsConfig):
        return prbs(cfg, int(params.get("seed", 0)))  # type: ignore[call-overload]
    if isinstance(cfg, MultilevelConfig):
        return multilevel(cfg, int(params.get("seed", 0)))  # type: ignore[call-overload]
    return steps(cfg)
