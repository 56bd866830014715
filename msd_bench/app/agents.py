"""The agent kinds of Table 1, and the learner each one gets — chosen here and nowhere else.

An agent kind is a surrogate (a registered model kind, or the true plant) ×
a learner design. The kinds follow from the model registry: every model kind
``m`` gives ``m`` (the paper's agent) and ``m+improved`` (our extension), so a
new model kind needs no edit here. Kept free of torch and python-control so
the command line lists and checks kinds instantly.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from msd_bench.core.errors import ConfigError
from msd_bench.core.qconfig import QConfig, improved_config
from msd_bench.core.registry import MODEL_KINDS

if TYPE_CHECKING:  # Dyna-Q's module loads the compiled learner (numba)
    from msd_bench.core.dyna import DynaConfig

PLANT = "plant"
"""Surrogate name of the on-plant learners (Q-learning on the true plant, Dyna-Q)."""

LEARNERS: dict[str, Callable[[], QConfig]] = {
    "paper": QConfig,
    "improved": improved_config,
}
"""Learner designs: ``paper`` is §4 as printed; ``improved`` is our extension (lead-error state)."""

PAPER_BUDGET_EPISODES = 300
"""The paper's training budget in episodes (each 3,000 steps)."""


@dataclass(frozen=True)
class AgentKind:
    """One row of Table 1: what the agent learns on and how it sees the state."""

    kind: str
    """Machine name used in reports and on the command line."""
    label: str
    """Human label."""
    surrogate: str
    """A registered model kind, or ``plant`` (the on-plant learners)."""
    agent: str
    """Learner design, a key of :data:`LEARNERS`."""
    dyna: bool = False
    """Dyna-Q with planning on the true plant (paper §3.4.2)."""


def _kinds() -> dict[str, AgentKind]:
    paper = [AgentKind(m.name, f"{m.label} (paper agent)", m.name, "paper") for m in MODEL_KINDS.values()]
    on_plant = [AgentKind("dyna-q", "Dyna-Q on the plant (paper agent)", PLANT, "paper", dyna=True),
                AgentKind(PLANT, "Q-learning on the true plant (reference)", PLANT, "paper")]
    improved = [AgentKind(f"{m.name}+improved", f"{m.label} (improved agent)", m.name, "improved")
                for m in MODEL_KINDS.values()]
    improved.append(AgentKind(f"{PLANT}+improved", "Q-learning on the true plant (improved agent)", PLANT,
                              "improved"))
    return {k.kind: k for k in (*paper, *on_plant, *improved)}


AGENT_KINDS: dict[str, AgentKind] = _kinds()
"""Every agent kind, in report order."""


def agent_kind(name: str) -> AgentKind:
    """The agent kind ``name``; a one-line ConfigError listing the kinds otherwise."""
    try:
        return AGENT_KINDS[name]
    except KeyError:
        raise ConfigError(f"unknown agent kind {name!r}; choose from {', '.join(AGENT_KINDS)}") from None


def check_agents(agents: Sequence[str]) -> None:
    """One-line ConfigError unless every kind is known and given once."""
    for a in agents:
        agent_kind(a)
    if not agents or len(set(agents)) != len(agents):
        raise ConfigError(f"agent kinds must be given once each, got {list(agents)}")


def parse_agents(text: str) -> tuple[str, ...]:
    """``"plm, plm+improved"`` → ``("plm", "plm+improved")``, checked."""
    agents = tuple(a.strip() for a in text.split(",") if a.strip())
    check_agents(agents)
    return agents


def surrogates_of(agents: Sequence[str]) -> list[str]:
    """Registered model kinds that at least one of ``agents`` trains on, in registry order."""
    need = {agent_kind(a).surrogate for a in agents}
    return [m for m in MODEL_KINDS if m in need]


def learner_config(kind: str, episodes: int, steps: int, force: float) -> QConfig:
    """The learner of agent kind ``kind`` at the given budget and force limit."""
    base = LEARNERS[agent_kind(kind).agent]()
    return replace(base, episodes=episodes, steps=steps, force=force)


def dyna_config(kind: str, episodes: int, steps: int, force: float, planning_steps: int) -> DynaConfig:
    """Dyna-Q's configuration: the kind's learner plus planning updates per real step."""
    from msd_bench.core.dyna import DynaConfig

    return DynaConfig(learner_config(kind, episodes, steps, force), planning_steps=planning_steps)


def budget_note(kind: str, dyna_episodes: int) -> str:
    """What a reader must know about a row's budget ('' when it is the paper's)."""
    if agent_kind(kind).dyna and dyna_episodes != PAPER_BUDGET_EPISODES:
        return (f"reduced budget: {dyna_episodes} Dyna-Q episodes instead of the paper's "
                f"{PAPER_BUDGET_EPISODES} (each is 3,000 real steps on the plant)")
    return ""


def learner_from_meta(meta: Mapping[str, Any]) -> QConfig:
    """The learner config stored with a Q-table artifact (JSON lists back to tuples)."""
    doc = meta.get("learner")
    if not isinstance(doc, dict):
        raise ConfigError("Q-table artifact carries no learner config (written by an older msd-bench)")
    fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in doc.items()}
    try:
        return QConfig(**fields)
    except TypeError as exc:
        raise ConfigError(f"Q-table artifact's learner config does not fit this msd-bench: {exc}") from None
