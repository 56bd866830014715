"""The experiment plan of one identification seed: which records, their signals, lengths and seeds.

Shared by the in-process run (which simulates each experiment) and bench.py's
recording stage (which plays each through an excitation node and records a
bag), so both identify from the same signals. Paper §3.2/§3.4: five ±1 N PRBS
experiments around the bias forces for the PLM's local models, one multilevel
record over the whole alphabet for GLM, NLARX and the grey-box model, and
validation twins of each with other seeds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Protocol, TypeVar

from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig
from msd_bench.core.identification.operating_points import PLM_BIASES

if TYPE_CHECKING:  # the scales import the plant (numba): not before bench.py's first node starts
    from msd_bench.core.rigs.scales import Scales

TRAIN, VALIDATION = "train", "validation"


@dataclass(frozen=True)
class PlannedExperiment:
    """One excitation experiment of the plan."""

    name: str
    """Directory-safe name, e.g. ``bias_m10``, ``broad``, ``val_bias_p5``."""
    role: str
    """``train`` or ``validation``."""
    bias: float | None
    """Operating-point force of a PRBS experiment, N; None for the broad record."""
    signal: PrbsConfig | MultilevelConfig
    """The excitation signal's configuration."""
    seed: int
    """Seed of the signal generator."""

    @property
    def kind(self) -> str:
        """Signal kind: ``prbs`` or ``multilevel``."""
        return "prbs" if isinstance(self.signal, PrbsConfig) else "multilevel"


def record_seeds(id_seed: int) -> tuple[int, int]:
    """(training, validation) base excitation seeds of an identification seed: never equal.

    PRBS seeds repeat modulo 1023; the offset 4,000 is not a multiple of it, so
    a validation record is always other data than the training record beside it.
    """
    return 1000 + 10 * id_seed, 5000 + 10 * id_seed


def paper_plan(id_seed: int, samples: int = 12_000, val_samples: int = 4_000,
               settle: int = PrbsConfig.settle, scales: Scales | None = None) -> list[PlannedExperiment]:
    """Training experiments then their validation twins, for identification seed ``id_seed``.

    ``settle`` samples at the bias force precede each PRBS record (dropped for
    identification, but real samples all the same: the data-efficiency curve
    counts them). On a rig of ``scales`` (docs/decisions.md §Scales) the bias forces, the PRBS
    amplitude and the multilevel alphabet are the paper's relative to its force limit, the PRBS
    bit and the multilevel dwells the paper's seconds; ``samples``, ``val_samples`` and ``settle``
    are the caller's, in rig samples. Experiments keep the paper's names (``bias_p10`` is the
    paper's +10 N on any rig); their ``bias`` is the rig's force.
    """
    plan: list[PlannedExperiment] = []
    for role, prefix, n, base in ((TRAIN, "", samples, record_seeds(id_seed)[0]),
                                  (VALIDATION, "val_", val_samples, record_seeds(id_seed)[1])):
        for i, bias in enumerate(PLM_BIASES):
            prbs = _on(PrbsConfig(bias=bias), scales)
            plan.append(PlannedExperiment(f"{prefix}{bias_name(bias)}", role, prbs.bias,
                                          replace(prbs, n_samples=n, settle=settle), base + i))
        broad = replace(_on(MultilevelConfig(), scales), n_samples=n)
        plan.append(PlannedExperiment(f"{prefix}broad", role, None, broad, base + 7))
    return plan


_Signal = TypeVar("_Signal", PrbsConfig, MultilevelConfig)


def _on(cfg: _Signal, scales: Scales | None) -> _Signal:
    """``cfg`` on a rig of ``scales``; itself when there are none (the paper's plant)."""
    return cfg if scales is None else cfg.scaled(scales)


def real_samples(plan: list[PlannedExperiment], records: str) -> int:
    """Plant samples a model kind consumes: its training records plus the broad validation record.

    ``records`` is the registry's ``broad`` or ``bias``; every kind is scored on
    the broad validation record, so that counts for every kind.
    """
    total = 0
    for e in plan:
        if consumed_by(e, records):
            settle = e.signal.settle if isinstance(e.signal, PrbsConfig) else 0
            total += e.signal.n_samples + settle
    return total


class Roled(Protocol):
    """What :func:`consumed_by` reads of an experiment: a planned one, or one played through a rig."""

    @property
    def role(self) -> str: ...
    @property
    def bias(self) -> float | None: ...


def consumed_by(e: Roled, records: str) -> bool:
    """Whether a model kind trained on ``records`` (``broad`` or ``bias``) uses experiment ``e``:
    its training records, and the broad validation record every kind is scored on."""
    return (e.role == VALIDATION and e.bias is None) or (
        e.role == TRAIN and (e.bias is None) == (records == "broad"))


def bias_name(bias: float) -> str:
    """``-10`` → ``bias_m10``, ``5`` → ``bias_p5``, ``0`` → ``bias_0``."""
    sign = "m" if bias < 0 else "p" if bias > 0 else ""
    return f"bias_{sign}{abs(bias):g}"
