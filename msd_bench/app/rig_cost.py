"""What a rig owner spends on one rig, in real samples: the one bill of every route on a rig.

Why one function: ``msd-bench rigs --refine`` (the refined rows' ``real_samples``) and the
data-efficiency curve on rigs (``msd-bench efficiency --rigs``: a point's x) both say what a
route cost; two bills that count different things cannot be read side by side. Both call
:func:`spent`.

A route is charged what it actually played on the rig, and the rests the rig took before each
(a rig has no reset: it gets zero force until its measured position is still, and those samples
are the owner's time too):

- the kind's own identification records, settle segments included (a broad-record kind: the
  broad training record; the PLM: its bias records), and the broad validation record every kind
  is scored on (:func:`msd_bench.app.plan.consumed_by`);
- a refined route's closed-loop tries on the rig and its fresh validation run.

Not charged: records of the plan the kind does not use (another kind's bias records), other
kinds' runs, the validation run that scores an open-loop row (it measures the route, as on the
ideal plant's curve), and the zero-force drain of the commands in flight after a closed-loop run
(the drive's dead time and decayed lag, before the next rest starts counting).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from msd_bench.app.plan import consumed_by

if TYPE_CHECKING:
    from msd_bench.core.rigs.rig_play import PlayedExperiment

ACCOUNTING = "route+rests"
"""The bill's name, written beside every count it makes (a JSON without it used an older one)."""

ACCOUNTING_TEXT = ("the kind's own records (settle segments included) and the broad validation record, "
                   "a refined route's tries and fresh run, each with the rest the rig took before it")
"""What :data:`ACCOUNTING` charges, in words (for reports)."""

Run = tuple[int, int]
"""A closed-loop run on the rig: (samples it played, zero-force samples of the rest before it)."""


def spent(played: Sequence[PlayedExperiment], records: str, runs: Sequence[Run] = ()) -> dict[str, int | str]:
    """The real samples a route spent on a rig whose plan was ``played``: its kind's ``records``
    (``broad`` or ``bias``, the registry's) and the broad validation record, then ``runs`` (a
    refined route's tries and fresh run), each with its rest; ``total`` is what the route costs."""
    used = [p for p in played if consumed_by(p, records)]
    bill = {"records": sum(len(p.command) for p in used), "record_rests": sum(p.rest.samples for p in used),
            "runs": sum(n for n, _ in runs), "run_rests": sum(rest for _, rest in runs)}
    return {"accounting": ACCOUNTING, **bill, "total": sum(bill.values())}


__all__ = ["ACCOUNTING", "ACCOUNTING_TEXT", "Run", "spent"]
