"""Controller designs behind one protocol (:mod:`.protocol`) and one registry (:mod:`.registry`).

Callers use only what is here: make a policy for a kind, run it nominally,
save it, load it back. Nothing here imports rclpy or torch; a design module's
heavy imports happen inside it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from msd_bench.core.errors import ConfigError
from msd_bench.designs.protocol import (
    Controller,
    Design,
    Drive,
    Facts,
    FloatArray,
    KindSpec,
    Policy,
    Request,
    Settings,
    Stepwise,
)
from msd_bench.designs.registry import (
    AGENT_KINDS,
    DESIGNS,
    PLANT,
    AgentKind,
    agent_kind,
    design,
    register,
    unregister,
)

if TYPE_CHECKING:  # numba-compiled modules load only when a policy is made or run
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.physics.plant import PlantParams

__all__ = [
    "AGENT_KINDS",
    "DESIGNS",
    "PLANT",
    "AgentKind",
    "Controller",
    "Design",
    "Drive",
    "Facts",
    "KindSpec",
    "Policy",
    "Request",
    "Settings",
    "Stepwise",
    "agent_kind",
    "at_decisions",
    "budget_note",
    "check_decisions",
    "design",
    "load",
    "make",
    "members",
    "nominal_runs",
    "register",
    "request",
    "stepwise",
    "unregister",
]


def request(kind: str, model: StepModel | None, settings: Settings, seeds: Sequence[int],
            drive: Drive | None = None) -> Request:
    """The request for ``kind`` (an unknown kind is one ConfigError line); ``drive``: what it is told of
    the drive (None: nothing)."""
    if not seeds:
        raise ConfigError(f"{kind}: need at least one learning seed")
    model, settings, drive = at_decisions(kind, model, settings, drive)
    return Request(agent_kind(kind).spec, model, settings, tuple(int(s) for s in seeds), drive)


def check_decisions(kind: str, samples_per_decision: int) -> None:
    """One line when ``kind``'s design cannot decide every ``samples_per_decision`` samples (it has not
    opted in with ``holds_decisions``): checked before a run starts anything."""
    if samples_per_decision != 1 and not getattr(agent_kind(kind).design, "holds_decisions", False):
        raise ConfigError(f"{kind}: a decision period of {samples_per_decision} rig samples is not supported "
                          f"by its design yet (the Q-learning kinds hold their command); drop the kind or "
                          f"give decision_period = the sample period")


def at_decisions(kind: str, model: StepModel | None, settings: Settings,
                 drive: Drive | None) -> tuple[StepModel | None, Settings, Drive | None]:
    """The request as a design deciding every ``settings.decision_samples`` rig samples sees it: the
    model held over them (:func:`msd_bench.core.physics.model.held`), the decision period as ``dt``,
    episodes of as many decisions as fit in the samples, a drive's dead time in decisions. Unchanged
    (the same objects) at one sample per decision. Why here: one place for every engine (in-process,
    the agent node), and no design's loop changes. A design that has not opted in (``holds_decisions``)
    is one line."""
    n = int(settings.decision_samples)
    if n == 1:
        return model, settings, drive
    check_decisions(kind, n)
    from msd_bench.core.physics.model import held  # numba: loaded only when a model is held

    told = None if drive is None else replace(drive, delay_samples=round(drive.delay_samples / n))
    decided = replace(settings, dt=settings.dt * n, steps=max(1, settings.steps // n), decision_samples=1)
    return None if model is None else held(model, n), decided, told


def make(kind: str, model: StepModel | None, settings: Settings, seeds: Sequence[int],
         drive: Drive | None = None) -> Policy:
    """Design or train ``kind`` in-process on ``model`` (the surrogate, or the plant's own model)."""
    return agent_kind(kind).design.make(request(kind, model, settings, seeds, drive))


def stepwise(kind: str, model: StepModel | None, settings: Settings, seeds: Sequence[int],
             drive: Drive | None = None) -> Stepwise | None:
    """Training of ``kind`` over topics (None: the design is made in-process only)."""
    return agent_kind(kind).design.stepwise(request(kind, model, settings, seeds, drive))


def members(kind: str, seeds: Sequence[int]) -> list[int]:
    """The members a policy of ``kind`` has for learning ``seeds``: one per seed, or a deterministic
    design's one (what a run counts as n when the policy could not even be made)."""
    return list(seeds)[:1] if agent_kind(kind).design.deterministic else list(seeds)


def budget_note(kind: str, settings: Settings) -> str:
    """What a reader must know about the budget of a row of ``kind`` ('' when it is the paper's)."""
    return agent_kind(kind).design.budget_note(settings)


def nominal_runs(policy: Policy, plant: PlantParams, target: float,
                 steps: int) -> tuple[FloatArray, FloatArray]:
    """The nominal validation: each member (a deterministic policy: its one) from rest on ``plant``."""
    from msd_bench.core.evaluation.closed_loop import nominal
    from msd_bench.core.physics.model import plant_model

    rows = policy.facts.nominal_rows(policy.members)
    return policy.rollout(plant_model(plant).kernel, nominal(target), np.zeros((rows, int(steps))))


def save(policy: Policy, directory: Path, provenance: dict[str, Any], root: Path,
         overwrite: bool = False) -> list[Path]:
    """Write ``policy``'s artifact into ``directory``."""
    return policy.save(Path(directory), provenance, root, overwrite)


def load(directory: Path, model: StepModel | None) -> Policy:
    """The policy saved in ``directory`` (``policy.json`` names its design), made on ``model``."""
    from msd_bench.io.storage import artifacts

    doc = artifacts.load_policy(Path(directory) / "policy.json")
    kind = agent_kind(str(doc["kind"]))
    if kind.agent != doc["design"]:
        raise artifacts.ArtifactError(f"{directory}: kind {kind.kind!r} is made by {kind.agent!r}, "
                                      f"not {doc['design']!r}")
    try:
        return kind.design.load(doc, Path(directory), model)
    except ConfigError as exc:
        raise artifacts.ArtifactError(f"{directory}: {exc}") from None
