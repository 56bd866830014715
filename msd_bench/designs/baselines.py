"""The classical baselines as designs: ``pid``, ``pid-continuous``, ``lqr``, ``mpc`` on identified models.

Each wraps one line of :data:`msd_bench.core.baselines.catalogue.CATALOGUE`
(the tuning rules, compiled rollouts and stepwise classes live in core), so a
new baseline is its core module and one catalogue line, and no edit here. A
baseline is deterministic: designed once per identified model and set-point,
so its policy has one member and a run counts identification seeds (and noise
draws), never copies. Why it redesigns at a scenario's set-point: the rule
takes the set-point as its operating point, as an engineer would retune.
Python-control and numba load only when a baseline is designed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.baselines.catalogue import CATALOGUE
from msd_bench.core.errors import ConfigError
from msd_bench.designs.protocol import Controller, Facts, KindSpec, PolicyBase, Request, Settings
from msd_bench.designs.registry import plus_kinds

if TYPE_CHECKING:  # numba-compiled modules load only when a policy is made or run
    from msd_bench.core.evaluation.closed_loop import Conditions
    from msd_bench.core.physics.kernels import Kernel
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.physics.plant import PlantParams

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class BaselinePolicy(PolicyBase):
    """One baseline designed on one model; redesigned (and cached) per set-point it is asked to track."""

    name: str
    """Entry of the core table (``pid``, ``pid-continuous``, ``lqr``, ``mpc``)."""
    model: StepModel
    """The identified model it was designed on."""
    force: float
    dt: float
    target: float
    """The nominal set-point; the artifact describes the design there."""
    options: Mapping[str, Any] = field(default_factory=dict)
    """Keyword options of the core design (``crossover``, ``horizon``, ...): a design study's knobs;
    the registry's kinds use the defaults."""
    _designs: dict[float, Any] = field(default_factory=dict, compare=False, repr=False)

    def design_at(self, target: float) -> Any:
        """The core design for ``target`` (made once)."""
        from msd_bench.core.baselines import designs

        t = float(target)
        if t not in self._designs:
            self._designs[t] = designs.make(self.name, self.model, t, self.force, self.dt, **self.options)
        return self._designs[t]

    def rollout(self, plant: Kernel, cond: Conditions, noise: FloatArray) -> tuple[FloatArray, FloatArray]:
        from msd_bench.core.baselines import designs

        xs, us = designs.entry(self.name).rollout(plant, self.design_at(cond.target), cond, noise)
        return xs, us

    def controller(self, member: int, target: float) -> Controller:
        from msd_bench.core.baselines import designs

        if member != 0:
            raise ConfigError(f"{self.kind} is deterministic: it has one member, not {member + 1}")
        return designs.entry(self.name).controller(self.design_at(target))

    def artifact(self) -> dict[str, Any]:
        """The design at the nominal set-point (gains, margins, bandwidth, horizon, observer gain)."""
        return {"design": self.design_at(self.target).as_dict(), "model": self.model.name,
                "target": self.target, "force": self.force, "dt": self.dt}

    def save(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool) -> list[Path]:
        return [self.write_policy(directory, provenance, root, overwrite, {}, self.artifact())]


@dataclass(frozen=True)
class BaselineDesign:
    """A registry entry over the core baseline ``name``."""

    name: str
    summary: str
    label: str
    baseline: bool = True
    deterministic: bool = True
    model_free: bool = False
    holds_decisions: bool = True
    """Designed on the surrogate held over a decision (:func:`msd_bench.designs.at_decisions`): its gains,
    observer and horizon then act per decision, as a controller deciding at that period's are."""

    def kinds(self, surfaces: Sequence[tuple[str, str]]) -> list[KindSpec]:
        return plus_kinds(self.name, self.label, False, surfaces)

    def budget_note(self, s: Settings) -> str:
        return ""

    def _policy(self, kind: str, seeds: Sequence[int], model: StepModel, s: Settings) -> BaselinePolicy:
        return BaselinePolicy(kind, (int(seeds[0]),), Facts(self.name, True, True, 0), self.name, model,
                              float(s.force), float(s.dt), float(s.target))

    def make(self, req: Request) -> BaselinePolicy:
        if req.model is None:
            raise ConfigError(f"{req.spec.kind}: a baseline is designed on an identified model")
        policy = self._policy(req.spec.kind, req.seeds, req.model, req.settings)
        policy.design_at(policy.target)  # design now: a model it cannot hold fails here, in one line
        return policy

    def stepwise(self, req: Request) -> None:
        return None

    def load(self, doc: dict[str, Any], directory: Path, model: StepModel | None) -> BaselinePolicy:
        """Redesign on ``model`` (deterministic) and check it is the design the artifact describes."""
        from msd_bench.io.storage import artifacts

        body = artifacts.policy_body(doc, directory, ("model", "target", "force", "dt", "design"))
        if model is None or model.name != body["model"]:
            raise artifacts.ArtifactError(f"{directory}: policy was designed on {body['model']!r}; "
                                          f"give that model")
        members = artifacts.policy_members(doc, directory)
        s = Settings(force=float(body["force"]), dt=float(body["dt"]), target=float(body["target"]))
        policy = self._policy(str(doc["kind"]), members, _at_decision(model, s.dt), s)
        if artifacts.jsonable(policy.artifact()) != body:
            raise artifacts.ArtifactError(f"{directory}: policy.json does not match the design its model "
                                          "gives (edited, or another model)")
        return policy


def _at_decision(model: StepModel, dt: float) -> StepModel:
    """``model`` held over the decision a design was made at (:func:`msd_bench.designs.at_decisions`):
    a policy designed every ``n`` rig samples states the decision's ``dt``, a whole ``n`` times the
    model's; at one sample per decision (or another ``dt``, which the redesign then refuses in one line)
    the model itself."""
    from msd_bench.core.physics.model import MAX_HELD, held

    n = round(dt / model.dt)
    if 2 <= n <= MAX_HELD and abs(n * model.dt - dt) <= 1e-9 * dt:
        return held(model, n)
    return model


def baseline_policy(name: str, model: StepModel, plant: PlantParams, seed: int = 0, target: float = 1.0,
                    **options: Any) -> BaselinePolicy:
    """Baseline ``name`` designed on ``model`` for ``plant``'s force limit and sample time with the
    core design's ``options``: one member (``seed``), its artifact the design at ``target``.

    Why outside the registry: a design study (scripts/baselines_check.py) evaluates one model and
    varies the options, which a kind's request has no field for; it then scores the policy through
    :func:`msd_bench.core.evaluation.robustness.evaluate_policy`, the one evaluator, as every kind is.
    An unknown design or option is a one-line ``ConfigError`` here, before any run.
    """
    policy = BaselinePolicy(f"{model.name}+{name}", (int(seed),), Facts(name, True, True, 0), name, model,
                            float(plant.F), float(plant.dt), float(target), dict(options))
    policy.design_at(policy.target)
    return policy


DESIGNS = tuple(BaselineDesign(b.name, b.summary, b.label) for b in CATALOGUE)
"""The baseline entries of the registry: one per line of the core catalogue."""
