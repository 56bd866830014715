"""The protocol every controller design follows: a design makes a policy; a policy runs, saves and draws.

Why one protocol: Table 1, robustness, the efficiency sweep, the agent node and
the report used to switch on what a kind was (a Q-learner, Dyna-Q, on the
plant). Each of those questions is now a fact or a method of the design or of
the policy it made, so a new controller is one module and one registry entry
(:mod:`msd_bench.designs.registry`) and no caller changes.

* A :class:`Design` turns a :class:`Request` — the model to design or train on
  (a surrogate, or the plant itself), the run's :class:`Settings`, the seeds —
  into a :class:`Policy`, in-process (:meth:`Design.make`) or, for designs that
  learn step by step, over a plant-like node's topics (:meth:`Design.stepwise`).
* A :class:`Policy` has (a) a compiled batch rollout with the semantics of
  :func:`msd_bench.core.evaluation.closed_loop.greedy_under`, (b) a stepwise
  :class:`Controller` per member for the agent node over ROS, (c) an artifact
  (:meth:`Policy.save`, loaded back by :meth:`Design.load`), (d) its figures and
  (e) its :class:`Facts`.

No rclpy and no torch here: a design's heavy imports happen inside it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.rigs.hold import HoldLoop

if TYPE_CHECKING:  # numba-compiled modules load only when a policy is made or run
    from msd_bench.core.evaluation.closed_loop import Conditions
    from msd_bench.core.physics.kernels import Kernel
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.rigs.scales import Scales


FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Settings:
    """What a design takes from the run (the same values in-process and in an agent node)."""

    episodes: int = 300
    """Training episodes per seed on a surrogate (paper: 300)."""
    steps: int = 3000
    """Steps per training episode (paper: 3,000)."""
    plant_episodes: int = 300
    """Episodes of a learner whose every step is a real sample and which plans between them (Dyna-Q)."""
    planning_steps: int = 100
    """Dyna-Q planning updates per real step (paper: 100)."""
    force: float = 10.0
    """Force limit F of the actuator and of the five-force alphabet, N."""
    dt: float = 0.01
    """Sample time, s."""
    stroke: float = 5.0
    """The plant's full travel, m: with ``force`` and ``dt`` it gives the scales the learners'
    paper constants are multiplied by (docs/decisions.md §Scales; 1.0 each on the paper's plant)."""
    target: float = 1.0
    """Nominal validation set-point, m."""
    shaping: str = "toward"
    """The run's reading of the paper's shaping term (a kind may pin its own)."""
    decision_samples: int = 1
    """Rig samples per decision: the command is held over them (docs/rig-description.md). A design
    sees the decision period as its ``dt`` and the model held over them
    (:func:`msd_bench.designs.request`)."""
    pace: float = 1.0
    """The rig's time unit against the paper's (:attr:`msd_bench.core.rigs.scales.Scales.pace`; 1.0:
    durations in seconds)."""

    def scales(self) -> Scales:
        """The scales of the plant these settings describe (exactly the default's on the paper's plant)."""
        from msd_bench.core.rigs.scales import Scales

        return Scales.of(self.stroke, self.force, self.dt, self.pace)


_SETTINGS_FIELDS = tuple(f.name for f in fields(Settings))


def settings_from(params: Mapping[str, Any]) -> Settings:
    """The one way a run's budgets become :class:`Settings`: from the agent job's parameters (the
    in-process run builds them with :func:`msd_bench.app.job.agent_params`, an agent node reads them
    from its job), so the two engines cannot tell a design different budgets."""
    return Settings(**{f: params[f] for f in _SETTINGS_FIELDS})


class KindSpec(NamedTuple):
    """One agent kind a design offers: its name, label, what it trains on and a pinned shaping."""

    kind: str
    """Machine name (``glm+pid``, ``plm``, ``dyna-q``)."""
    label: str
    """Human label for every table."""
    surrogate: str
    """A registered model kind, or ``plant``."""
    shaping: str | None = None
    """Shaping reading pinned by the kind (``plm@away``); None = the run's."""


@dataclass(frozen=True)
class Drive:
    """What a design may know of the drive between its commands and the applied force.

    Why part of the request: a rig's (or a foreign node's) records show a dead time
    and a lag between the commanded force and the effort; whether a design is told
    them is the protocol's business, not a caller's per design. Measured from the
    broad record's commands and effort
    (:func:`msd_bench.core.rigs.actuation.effort_agreement`).
    """

    delay_samples: int
    """Dead time, samples."""
    lag_s: float
    """First-order lag's time constant, s."""
    hold: HoldLoop | None = None
    """The position loop the drive adds to every command (a stage's, docs/rig-families.md §stage;
    None: a bare drive): the rig's owner states it, so a design may know it."""


@dataclass(frozen=True)
class Request:
    """Everything a design is given to make a policy."""

    spec: KindSpec
    """The kind being made."""
    model: StepModel | None
    """What it designs or trains on: the identified surrogate, or the plant's own model (None: an
    on-plant learner over topics that never reads one)."""
    settings: Settings
    """The run's budgets and actuator."""
    seeds: tuple[int, ...]
    """Learning seeds (a deterministic design keeps the first one as its member's name)."""
    drive: Drive | None = None
    """The drive its records show (None: told nothing, the design assumes an ideal drive)."""


@dataclass(frozen=True)
class Facts:
    """What a report must know about a policy without knowing its design."""

    design: str
    """Registry name of the design that made it."""
    baseline: bool
    """A classical baseline (designed, not learned)."""
    deterministic: bool
    """Same input, same policy: one nominal run per identified model; copies would not count as n."""
    real_interactions: int
    """Samples it really spent on the true plant while training (0 for a design on a surrogate)."""

    def nominal_rows(self, members: Sequence[int]) -> int:
        """Runs of a nominal validation: one per member; a deterministic policy's copies are not n."""
        return 1 if self.deterministic else len(members)

    def noise_draws(self, members: Sequence[int], seeds: Sequence[int], noisy: bool) -> list[int]:
        """The noise streams it runs under a scenario: one per member; a deterministic policy one per
        seed where the scenario draws sensor noise (``noisy``) and a single run otherwise."""
        if not self.deterministic:
            return list(members)
        return list(seeds) if noisy else list(seeds)[:1]

    def member_of_runs(self, runs: int) -> list[int]:
        """The member (an index) that makes each of ``runs`` runs: row j's own, or the one member of a
        deterministic policy on every row."""
        return [0] * runs if self.deterministic else list(range(runs))

    def table_note(self) -> str:
        """What Table 1 says about how its rows were run ('' for learned, stochastic policies)."""
        if not self.deterministic:
            return ""
        return ("deterministic baseline: one nominal run per identified model" if self.baseline
                else "deterministic: one nominal run per identified model")


class Controller(Protocol):
    """The stepwise face an agent node drives, one sample at a time."""

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``, m."""


class Policy(Protocol):
    """A trained or designed controller over its members (one per learning seed; deterministic: one)."""

    @property
    def kind(self) -> str:
        """The agent kind it is a row of."""

    @property
    def members(self) -> tuple[int, ...]:
        """Learning seeds of its members, in rollout order."""

    @property
    def facts(self) -> Facts:
        """Its facts (:class:`Facts`)."""

    def rollout(self, plant: Kernel, cond: Conditions, noise: FloatArray) -> tuple[FloatArray, FloatArray]:
        """True positions and commands (runs × steps) from rest under ``cond``; ``noise[j]`` is run j's
        measurement noise. A stochastic policy runs member j on row j; a deterministic one runs its
        single member on every row."""

    def controller(self, member: int, target: float) -> Controller:
        """The stepwise form of member ``member`` (an index) tracking ``target``."""

    def save(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool) -> list[Path]:
        """Write the artifact into ``directory`` (``policy.json`` and the design's own files)."""

    def figures(self, fig_dir: Path, root: Path) -> list[Path]:
        """Its own figures (Q-learners: their tables; others may draw nothing)."""


@dataclass(frozen=True)
class PolicyBase:
    """What the policies that are not Q-tables share: a kind, members, facts, ``policy.json``, no figures.

    Why here: the classical baselines and the deep-RL networks each carried the
    same three fields and the same ``policy.json`` writing and empty figures; a
    subclass adds its own fields, its rollout and controller, and hands
    :meth:`write_policy` its files by role and its body.
    """

    kind: str
    """The agent kind it is a row of."""
    members: tuple[int, ...]
    """Learning seeds of its members, in rollout order (a deterministic policy: one)."""
    facts: Facts
    """Its facts."""

    def write_policy(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool,
                     files: dict[str, str], body: dict[str, Any]) -> Path:
        """``directory/policy.json`` naming the design's ``files`` beside it, with ``body``."""
        from msd_bench.io.storage import artifacts

        doc = artifacts.policy_doc(self.kind, self.facts, self.members, provenance, files, body)
        return artifacts.save_policy(directory / "policy.json", doc, root=root, overwrite=overwrite)

    def figures(self, fig_dir: Path, root: Path) -> list[Path]:
        """None of its own (only Q-learners draw their tables)."""
        return []


class StepwiseLearner(Protocol):
    """One member learning over topics: the episode client drives it."""

    def start_episode(self, x0: float = 0.0) -> float:
        """Start an episode from the measured ``x0``."""

    def act(self) -> float:
        """The next force."""

    def learn(self, x_new: float) -> None:
        """Take the measured answer to the last force."""


class Stepwise(Protocol):
    """A design's training over a plant-like node's topics (Dyna-Q on the plant, Q-learning via a
    surrogate node): its learners, their budget, and the policy they made once done."""

    on_plant: bool
    """Its steps go to the plant (real samples) rather than to a surrogate node."""
    episodes: int
    """Episodes per learner."""
    steps: int
    """Steps per episode."""
    learners: Sequence[StepwiseLearner]
    """One per seed."""

    def finish(self) -> Policy:
        """The policy once every episode ran."""


class Design(Protocol):
    """One registry entry: how a family of kinds is made, trained over topics, and loaded back."""

    name: str
    """Registry name (the part after ``+``)."""
    summary: str
    """One line for reports and docs."""
    baseline: bool
    """A classical baseline."""
    deterministic: bool
    """Its policies are deterministic functions of the model (see :class:`Facts`)."""
    model_free: bool
    """It learns by its own steps on the plant's topics and reads no model file (Dyna-Q): bench.py
    starts it before identification, on the plant, at the plant budget."""

    def kinds(self, surfaces: Sequence[tuple[str, str]]) -> list[KindSpec]:
        """The kinds it offers over the registered surrogates ``(name, label)`` (and the plant)."""

    def make(self, req: Request) -> Policy:
        """Design or train in-process."""

    def budget_note(self, s: Settings) -> str:
        """What a reader must know about a row's budget ('' when it is the paper's)."""

    def stepwise(self, req: Request) -> Stepwise | None:
        """Training over topics, if the design learns step by step (None: :meth:`make` only)."""

    def load(self, doc: dict[str, Any], directory: Path, model: StepModel | None) -> Policy:
        """The policy from its artifact (``doc`` is ``policy.json``; ``model`` what it was made on)."""
