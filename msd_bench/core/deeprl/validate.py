"""What deep-RL design studies count on the standard suite's cells: the set-points a policy holds.

Scoring itself is the one evaluator's (:func:`msd_bench.core.evaluation.robustness.evaluate_policy`,
through :func:`msd_bench.designs.deeprl.nets_policy`): the same scenarios, noise streams and cells as
every other kind, so a deep-RL row sits beside them in Table 1 and the robustness table.
"""

from __future__ import annotations

from typing import Any

SETPOINT_IDS = ("nominal", "setpoint=-1.5", "setpoint=-0.5", "setpoint=0.5", "setpoint=1.5")
"""The set-point cells of the standard suite: what 'held k of 5 set-points' counts."""


def setpoints_held(cells: dict[str, dict[str, Any]]) -> int:
    """Set-point cells (of :data:`SETPOINT_IDS`) where every policy succeeded."""
    return sum(int(cells[s]["n_success"] == cells[s]["n"]) for s in SETPOINT_IDS if s in cells)
