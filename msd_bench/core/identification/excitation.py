"""Seeded excitation signals of the paper's experiments (§3.2, §3.3).

* :func:`prbs` — a maximum-length pseudo-random binary sequence of ±amplitude
  around a bias (the PLM's five operating-point experiments);
* :func:`multilevel` — pseudo-random switching over the action alphabet with
  minimum/maximum dwell (the NLARX and GLM record);
* :func:`steps` — a staircase of constant levels.

Every generator is a pure function of its config and seed and returns one
force per sample; the same seed always gives the same signal.

Every config checks its fields' types and bounds when it is built (a signal is
at most :data:`MAX_SIGNAL_SAMPLES` long, every force finite), so a config read
from a file — a bag's stored parameters — is refused with one line before any
array is allocated, whoever builds it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError

if TYPE_CHECKING:  # the scales import the plant (numba); the plan reads these configs before any node starts
    from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]

# Feedback taps of maximum-length Fibonacci LFSRs (Xilinx XAPP052).
_LFSR_TAPS = {7: (7, 6), 9: (9, 5), 10: (10, 7), 11: (11, 9), 15: (15, 14)}

MAX_SIGNAL_SAMPLES = 10_000_000
"""Longest signal a config may describe: 28 h at 100 Hz (80 MB of float64). Why a bound: a slip
or a crafted bag (``steps.dwell = 1e13``) would otherwise ask for terabytes."""
MAX_LEVELS = 10_000
"""Most forces a multilevel or steps config may list."""
MAX_SEED = 2**64 - 1
"""Largest seed accepted (numpy's generators take any non-negative integer; 64 bits is plenty)."""


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
        _finite("bias", self.bias)
        _require(_finite("amplitude", self.amplitude) > 0, "amplitude must be > 0")
        _count("n_samples", self.n_samples, 1)
        _count("hold", self.hold, 1)
        _count("settle", self.settle, 0)
        _require(_is_int(self.register_bits) and self.register_bits in _LFSR_TAPS,
                 f"register_bits must be one of {sorted(_LFSR_TAPS)}, got {self.register_bits!r:.60}")
        _total(self.settle + self.n_samples, "settle + n_samples")

    def scaled(self, scales: Scales) -> PrbsConfig:
        """This signal, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md §Scales):
        bias and amplitude relative to the force limit, record, bit and settle lengths in seconds.
        Unchanged, bit for bit, on the paper's plant."""
        if scales.is_default:
            return self
        return replace(self, bias=scales.newtons(self.bias), amplitude=scales.newtons(self.amplitude),
                       n_samples=scales.samples(self.n_samples), hold=scales.samples(self.hold),
                       settle=scales.samples(self.settle))


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
        object.__setattr__(self, "levels", _levels(self.levels, 2))
        _count("n_samples", self.n_samples, 1)
        _count("min_dwell", self.min_dwell, 1)
        _count("max_dwell", self.max_dwell, 1)
        _require(self.min_dwell <= self.max_dwell, "need 1 <= min_dwell <= max_dwell")

    def scaled(self, scales: Scales) -> MultilevelConfig:
        """This signal on a rig of ``scales``: levels relative to the force limit, lengths and dwell
        limits in seconds (docs/decisions.md §Scales). Unchanged, bit for bit, on the paper's plant."""
        if scales.is_default:
            return self
        return replace(self, levels=tuple(scales.newtons(v) for v in self.levels),
                       n_samples=scales.samples(self.n_samples), min_dwell=scales.samples(self.min_dwell),
                       max_dwell=scales.samples(self.max_dwell))


@dataclass(frozen=True)
class StepsConfig:
    """A staircase: each level held for ``dwell`` samples."""

    levels: tuple[float, ...] = field(default=(0.0, 5.0, 0.0, -5.0))
    """Forces in order, N."""
    dwell: int = 1_000
    """Samples per level."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "levels", _levels(self.levels, 1))
        _count("dwell", self.dwell, 1)
        _total(len(self.levels) * self.dwell, "len(levels) * dwell")

    def scaled(self, scales: Scales) -> StepsConfig:
        """This staircase on a rig of ``scales``: levels relative to the force limit, the dwell in
        seconds (docs/decisions.md §Scales). Unchanged, bit for bit, on the paper's plant."""
        if scales.is_default:
            return self
        return replace(self, levels=tuple(scales.newtons(v) for v in self.levels),
                       dwell=scales.samples(self.dwell))


def prbs_bits(n_bits: int, register_bits: int, seed: int) -> NDArray[np.int8]:
    """``n_bits`` values in {-1, +1} from a maximum-length LFSR started at a seeded state.

    A maximum-length register returns to its start state after ``2^bits - 1``
    steps, so one period is computed bit by bit and repeated: the same bits as
    running the register ``n_bits`` times, without a Python loop of millions.
    """
    a, b = _LFSR_TAPS[register_bits]
    period = (1 << register_bits) - 1
    state = 1 + (seed % period)  # never the all-zero lock-up state
    out = np.empty(min(n_bits, period), dtype=np.int8)
    for i in range(out.size):
        bit = ((state >> (a - 1)) ^ (state >> (b - 1))) & 1
        state = ((state << 1) | bit) & period
        out[i] = 1 if bit else -1
    return np.resize(out, n_bits) if n_bits > out.size else out


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


def _is_int(value: object) -> bool:
    """An integer that is not a bool (``True`` as a sample count is a slip, not 1)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def _finite(name: str, value: object) -> float:
    """``value`` as a float, if it is a finite real number (not a bool, not a string)."""
    number = finite_or_nan(value)
    if not math.isfinite(number):
        raise ConfigError(f"{name} must be a finite number, got {value!r:.60}")
    return number


def finite_or_nan(value: object) -> float:
    """``value`` as a float if it is a real number (not a bool); NaN otherwise, and for ints beyond float."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        return math.nan
    return _as_float(value)


def _as_float(value: float | np.integer | np.floating) -> float:
    try:
        return float(value)
    except OverflowError:  # an int beyond float's range
        return math.nan


def _count(name: str, value: object, low: int) -> None:
    """A sample count: an integer in ``[low, MAX_SIGNAL_SAMPLES]``."""
    if not _is_int(value):
        raise ConfigError(f"{name} must be an integer number of samples, got {value!r:.60}")
    if int(value) < low:  # type: ignore[call-overload]
        raise ConfigError(f"{name} must be >= {low}, got {value}")
    if int(value) > MAX_SIGNAL_SAMPLES:  # type: ignore[call-overload]
        raise ConfigError(f"{name} must be <= {MAX_SIGNAL_SAMPLES}, got {value}")


def _total(samples: int, what: str) -> None:
    """Refuse a signal longer than :data:`MAX_SIGNAL_SAMPLES` before it is allocated."""
    if samples > MAX_SIGNAL_SAMPLES:
        raise ConfigError(f"the signal would be {what} = {samples} samples, more than {MAX_SIGNAL_SAMPLES}")


def _levels(levels: object, fewest: int) -> tuple[float, ...]:
    """``levels`` as a tuple of finite forces, between ``fewest`` and :data:`MAX_LEVELS` of them."""
    if not isinstance(levels, tuple | list | np.ndarray):
        raise ConfigError(f"levels must be a list of forces, got {type(levels).__name__}")
    if not fewest <= len(levels) <= MAX_LEVELS:
        need = "at least one force" if fewest == 1 else f"at least {fewest} forces"
        raise ConfigError(f"levels needs {need} and at most {MAX_LEVELS}, got {len(levels)}")
    return tuple(_finite(f"levels[{i}]", v) for i, v in enumerate(levels))


def check_seed(seed: object) -> int:
    """A generator seed: an integer in ``[0, MAX_SEED]`` (numpy refuses negative seeds)."""
    if not _is_int(seed) or not 0 <= int(seed) <= MAX_SEED:  # type: ignore[call-overload]
        raise ConfigError(f"seed must be an integer in [0, 2**64 - 1], got {seed!r:.60}")
    return int(seed)  # type: ignore[call-overload,no-any-return]


_CONFIGS: dict[str, type] = {"prbs": PrbsConfig, "multilevel": MultilevelConfig, "steps": StepsConfig}
SignalConfig = PrbsConfig | MultilevelConfig | StepsConfig


def config_from_params(params: Mapping[str, object]) -> tuple[SignalConfig, int] | None:
    """The signal config and seed a bag's parameters describe, checked; None if they store no config.

    Why separate from :func:`signal_from_params`: a reader checks every field
    (kind, names, types, bounds, seed) before anything is allocated, and can
    name the bag in its own error. Raises :class:`ConfigError` naming the field.
    """
    if "signal" not in params:
        return None
    kind = params["signal"]
    if not isinstance(kind, str) or kind not in _CONFIGS:
        raise ConfigError(f"signal must be one of {', '.join(_CONFIGS)}, got {kind!r}")
    raw = params.get(kind)
    if raw is None:
        return None  # the kind is named but its config was not stored: nothing to rebuild
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{kind} must be an object of the {kind} signal's fields, got {raw!r:.60}")
    known = {f.name for f in fields(_CONFIGS[kind])}
    unknown = sorted(str(k) for k in raw if k not in known)
    if unknown:
        names = ", ".join(k if k.isidentifier() else repr(k)[:40] for k in unknown[:5])
        raise ConfigError(f"{kind} has no field {names} (fields: {', '.join(sorted(known))})")
    values = {str(k): tuple(v) if isinstance(v, list) else v for k, v in raw.items()}
    try:
        cfg = _CONFIGS[kind](**values)
    except ConfigError as exc:
        raise ConfigError(f"{kind}: {exc}") from None
    seed = check_seed(params.get("seed", 0))
    return cfg, seed


def signal_from_params(params: Mapping[str, object]) -> FloatArray | None:
    """Regenerate a played signal from the parameters a bag stores; None if it stores none.

    A bag written by our recorder says which generator played (``signal``), its
    config (under the signal's name) and its ``seed``, so the exact command
    sequence can be rebuilt — e.g. to find where a real-time recording started.
    Every field is checked first (:func:`config_from_params`).
    """
    found = config_from_params(params)
    if found is None:
        return None
    cfg, seed = found
    if isinstance(cfg, PrbsConfig):
        return prbs(cfg, seed)
    if isinstance(cfg, MultilevelConfig):
        return multilevel(cfg, seed)
    return steps(cfg)
