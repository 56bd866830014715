"""Which agent kinds a run does by default, and what callers may ask of a kind: answered here.

Why here: the default rows of each command used to be literal kind names in
the application (``app/agents.py``, ``app/rigs.py``, ``app/plant_ns.py``,
``app/efficiency.py``), and questions such as "is it made on the plant?" or
"does it learn on the node?" were property checks spread over 13 files.
Both are knowledge about kinds, so they live beside the registry: a caller
asks a question by its purpose (:func:`model_file`, :func:`split_by_model`,
...) and never reads a kind's facts itself (``tests/designs/test_no_switches.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from msd_bench.designs.protocol import Facts, Settings, Stepwise
from msd_bench.designs.registry import AGENT_KINDS, PLANT, agent_kind

BENCH: tuple[str, ...] = ("glm", "plm", "nlarx-paper", "plm+improved", "plm+robust")
"""bench.py's default kinds: the paper's surrogate agents of Table 1 (GLM, PLM, NLARX) and our two agents
on its best surrogate. Every kind validates over DDS in lock-step, so each costs the graph what it costs
in-process many times over. Dyna-Q is one ``--agents`` away: its real steps at bench.py's token budget
(5 of the paper's 300 episodes) cost as many lock-step round trips as the five kinds' validations together,
for a row that is not the paper's Dyna-Q; the README's generated Table 1 has it at full budget. The full
matrix is ``msd-bench paper``'s default and ``--agents matrix`` here (docs/decisions.md §Main job)."""

PLANT_NS: tuple[str, ...] = (
    "glm+improved", "plm", "plm+improved", "plm+robust", "nlarx-improved+improved",
    "nlarx-improved+robust", "greybox+robust", "dyna-q")
"""Agent kinds of a ``--plant-ns`` run: the surrogate kinds that matter (the paper's PLM agent, our
improved and robust agents on the better surrogates) and Dyna-Q on the node; about an hour at full size."""

PLANT_NS_SCENARIO_KINDS: tuple[str, ...] = ("plm+robust", "nlarx-improved+robust")
"""Kinds of a ``--plant-ns`` run whose tables are also validated under its scenarios (each costs real
time)."""

QUICK_LOOK: tuple[str, ...] = ("glm+improved", "greybox+robust", "dyna-q")
"""The kinds of the README's quick look at a rig (no PLM, so only the two broad records are recorded)."""

QUICK_LOOK_SCENARIO_KINDS: tuple[str, ...] = ("greybox+robust",)
"""The quick look's kind validated under its scenario too."""

RIGS: tuple[str, ...] = ("plm", "nlarx-improved", "greybox", "plm+robust", "nlarx-improved+robust",
                         "greybox+robust")
"""``msd-bench rigs``' default kinds: the paper agent and the robust agent on three surrogates."""

RIG_SIMULATOR: str = "greybox-rig+robust"
"""The kind whose design makes ``msd-bench rigs --ceiling``'s row on each rig's own simulator: the robust
agent on a greybox-rig model, the one model kind whose kernel holds a rig's friction, lag and dead time
(filled with the rig's drawn values instead of fitted ones: ``core/rigs/truth.py``)."""

PLANT_SIMULATOR: str = "greybox+robust"
"""The kind whose design makes ``--ceiling``'s row on each rig's true plant (the grey-box kernel filled
with the rig's drawn parameters, no friction or drive): a perfect grey-box fit."""

EFFICIENCY_SURROGATE: tuple[str, ...] = ("plm+improved", "nlarx-improved+improved", "greybox+improved",
                                         "glm+improved")
"""The surrogate route of the data-efficiency curve (one line each)."""

RIG_EFFICIENCY: tuple[str, ...] = ("plm+robust", "nlarx-improved+robust", "greybox+robust")
"""The data-efficiency curve on rigs (``msd-bench efficiency --rigs``): the robust agent, told each rig's
drive, on the surrogates of ``msd-bench rigs``."""

EFFICIENCY_PLANT: tuple[str, ...] = ("plant+improved", "plant", "dyna-q")
"""The on-plant route of the data-efficiency curve (one line each)."""

_OFF_MATRIX = ("plant+improved", "plant+robust")
"""Our agents on the true plant: opt-in (they are references, not the paper's rows)."""


def matrix() -> tuple[str, ...]:
    """Every surrogate under every learner and the paper's on-plant references; the ``@`` readings,
    our agents on the true plant and every baseline (classical or deep) are opt-in."""
    return tuple(k for k in AGENT_KINDS if "@" not in k and k not in _OFF_MATRIX
                 and not AGENT_KINDS[k].design.baseline)


def made_on_plant(kind: str) -> bool:
    """It is made on the true plant (no identified model): once per run, not per identification seed."""
    return agent_kind(kind).on_plant


def is_baseline(kind: str) -> bool:
    """It is a baseline (classical or deep), not one of the paper's learned agents: reports compare the
    learned kinds against these."""
    return agent_kind(kind).design.baseline


def split_by_model(agents: Sequence[str]) -> tuple[list[str], list[str]]:
    """``agents`` as (made on an identified model, made on the plant), each in the given order."""
    return ([a for a in agents if not made_on_plant(a)], [a for a in agents if made_on_plant(a)])


def learns_on_node(kind: str) -> bool:
    """It learns by its own steps on the plant node's topics and reads no model file (Dyna-Q, on-plant
    deep RL): bench.py starts it before identification, at the plant budget."""
    return agent_kind(kind).design.model_free


def on_node(agents: Sequence[str]) -> list[str]:
    """The kinds of ``agents`` that learn on the plant node (:func:`learns_on_node`)."""
    return [a for a in agents if learns_on_node(a)]


def model_file(kind: str) -> str | None:
    """The model (``models/<name>.json``) a kind is made on: its surrogate, ``plant`` for a learner on
    the emulator's own model; None for a kind that learns on the node and reads none."""
    return None if learns_on_node(kind) else agent_kind(kind).surrogate


def trains_via_surrogate_node(kind: str) -> bool:
    """It can train over a surrogate node's topics (``--via-ros``): made on an identified model."""
    return not made_on_plant(kind) and not learns_on_node(kind)


def on_emulator(kind: str) -> bool:
    """It learns on the emulator's own model (Q-learning on the true plant, not Dyna-Q): a foreign
    node (``--plant-ns``) has no such model."""
    return made_on_plant(kind) and not learns_on_node(kind)


def plant_references(kinds: Sequence[str]) -> list[str]:
    """The on-plant Q-learners among ``kinds``: the references of the data-efficiency curve (a deep-RL
    or other baseline on the plant is a method like the others, never the reference)."""
    return [k for k in kinds if on_emulator(k) and not agent_kind(k).design.baseline]


def node_budget_note(kinds: Sequence[str], s: Settings) -> str:
    """What the report adds to the budget of the kinds that learn on the node: Dyna-Q's planning."""
    planners = [k for k in on_node(kinds) if getattr(agent_kind(k).design, "planning", False)]
    return f", {s.planning_steps} planning updates per real step (Dyna-Q)" if planners else ""


def stepwise_namespace(over: Stepwise, plant_ns: str, surrogate_ns: str) -> str:
    """Where a design's training over topics steps: the plant's node (real samples) or a surrogate's."""
    return plant_ns if over.on_plant else surrogate_ns


def stepwise_training(kind: str, over: Stepwise) -> str:
    """How ``result.json`` names training over topics: ``<design> over the plant`` or ``ros``."""
    return f"{agent_kind(kind).agent} over the plant" if over.on_plant else "ros"


def facts_record(facts: Facts | None) -> dict[str, Any]:
    """A policy's facts as ``result.json`` states them (no policy yet: nothing learned, nothing run)."""
    if facts is None:
        return {"baseline": False, "deterministic": False, "real_interactions": 0}
    return {"baseline": facts.baseline, "deterministic": facts.deterministic,
            "real_interactions": facts.real_interactions}


__all__ = [
    "BENCH",
    "EFFICIENCY_PLANT",
    "EFFICIENCY_SURROGATE",
    "PLANT",
    "PLANT_NS",
    "PLANT_NS_SCENARIO_KINDS",
    "PLANT_SIMULATOR",
    "QUICK_LOOK",
    "QUICK_LOOK_SCENARIO_KINDS",
    "RIGS",
    "RIG_SIMULATOR",
    "facts_record",
    "learns_on_node",
    "made_on_plant",
    "matrix",
    "model_file",
    "node_budget_note",
    "on_emulator",
    "on_node",
    "plant_references",
    "split_by_model",
    "stepwise_namespace",
    "stepwise_training",
    "trains_via_surrogate_node",
]
