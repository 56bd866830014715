"""The identification and validation records of one identification seed.

A plain container shared by every producer (in-process simulation, the
identifier node reading bags) and every consumer (the registry's fitters, the
fit figures), so none of them depends on the application layer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from msd_bench.core.identification.data import IOData


@dataclass(frozen=True)
class Records:
    """Identification and validation data of one identification seed."""

    bias_train: dict[float, IOData]
    """PRBS record per bias (settling dropped)."""
    bias_val: dict[float, IOData]
    """Validation PRBS record per bias (other seeds; may be empty: only figures use it)."""
    broad_train: IOData
    """Multilevel record for GLM, NLARX and the grey-box model."""
    broad_val: IOData
    """Validation multilevel record: every surrogate is scored on it."""
    closed_loop: tuple[IOData, ...] = field(default=())
    """Closed-loop tries on the rig (the applied force, the measured position), for a refit after a
    try: the broad kinds find them joined to ``broad_train``; the PLM, whose local models belong to
    its bias records, takes them into the refinement of its blend (``identify_plm``). Empty for an
    open-loop identification."""
