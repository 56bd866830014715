"""The PLM's operating points, apart from the code that identifies at them.

Why a module of its own: the experiment plan names them, and the plan is read
at the start of every ``bench.py`` run; importing them from :mod:`.plm`
pulled in SciPy's optimiser and python-control (1.7 s) before the first
node process could start.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the scales import the plant (numba), which this module exists to keep out
    from msd_bench.core.rigs.scales import Scales

PLM_BIASES = (-10.0, -5.0, 0.0, 5.0, 10.0)
"""The paper's bias forces, N, in the order of the memberships f1..f5."""


def plm_biases(scales: Scales | None = None) -> tuple[float, ...]:
    """The PLM's bias forces on a rig of ``scales``: the paper's, relative to the force limit
    (docs/decisions.md §Scales); :data:`PLM_BIASES` itself on the paper's plant."""
    if scales is None or scales.is_default:
        return PLM_BIASES
    return tuple(scales.newtons(b) for b in PLM_BIASES)
