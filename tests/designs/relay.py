"""A design that exists only in the tests: a proportional relay on the five forces.

It is registered at run time (:func:`msd_bench.designs.register`) and must then
run in both engines with no other edit (issue 22). Its controller is plain Python,
so it shares no code with any built-in design; its rollout is the one closed
loop's stepwise shape (a Python design supplies only its decision).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.core.baselines import base
from msd_bench.core.evaluation.closed_loop import Conditions, stepwise
from msd_bench.designs.protocol import Facts, KindSpec, Request, Settings
from msd_bench.designs.registry import plus_kinds
from msd_bench.io.storage import artifacts

GAIN = 12.0
"""N per m of error."""


class RelayController:
    """``u`` = the alphabet force nearest ``GAIN (target - y) + hold``."""

    def __init__(self, target: float, hold: float, forces: np.ndarray) -> None:
        self.target, self.hold, self.forces = target, hold, forces

    def reset(self) -> None:
        pass

    def act(self, y: float) -> float:
        return float(base.nearest(self.forces, GAIN * (self.target - base.measured(y)) + self.hold))


@dataclass(frozen=True)
class RelayPolicy:
    kind: str
    members: tuple[int, ...]
    facts: Facts
    hold: float
    force: float

    def controller(self, member: int, target: float) -> RelayController:
        return RelayController(target, self.hold, base.alphabet(self.force))

    def rollout(self, plant: Any, cond: Conditions, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        runs = [stepwise(self.controller(0, cond.target), plant, cond, row) for row in noise]
        return np.concatenate([t.x for t in runs]), np.concatenate([t.command for t in runs])

    def save(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool) -> list[Path]:
        doc = artifacts.policy_doc(self.kind, self.facts, self.members, provenance, {},
                                   {"hold": self.hold, "force": self.force})
        return [artifacts.save_policy(directory / "policy.json", doc, root=root, overwrite=overwrite)]

    def figures(self, fig_dir: Path, root: Path) -> list[Path]:
        return []


@dataclass(frozen=True)
class RelayDesign:
    name: str = "relay"
    summary: str = "a proportional relay (tests only)"
    baseline: bool = True
    deterministic: bool = True
    model_free: bool = False

    def kinds(self, surfaces: Sequence[tuple[str, str]]) -> list[KindSpec]:
        return plus_kinds(self.name, "relay baseline", False, surfaces)

    def budget_note(self, s: Settings) -> str:
        return ""

    def make(self, req: Request) -> RelayPolicy:
        assert req.model is not None
        hold = base.equilibrium_force(req.model, req.settings.target)
        return RelayPolicy(req.spec.kind, (req.seeds[0],), Facts(self.name, True, True, 0), hold,
                           req.settings.force)

    def stepwise(self, req: Request) -> None:
        return None

    def load(self, doc: dict[str, Any], directory: Path, model: Any) -> RelayPolicy:
        body = artifacts.policy_body(doc, directory, ("hold", "force"))
        return RelayPolicy(doc["kind"], artifacts.policy_members(doc, directory),
                           Facts(self.name, True, True, 0), float(body["hold"]), float(body["force"]))
