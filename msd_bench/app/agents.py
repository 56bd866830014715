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

def robust_config() -> QConfig:
    """Our robust agent: the improved agent's grid, seen through an observer that runs the surrogate as a
    predictor, trained under an actuator delay drawn per episode (docs/decisions.md §Robust agent says
    how the values were chosen)."""
    return improved_config(**ROBUST)


ROBUST: dict[str, object] = {"observer": "model", "obs_gain": 0.1, "obs_bias_gain": 8.0,
                             "obs_velocity_gain": 0.0, "obs_velocity_share": 0.3, "train_noise": 0.0,
                             "train_delay": 1, "select_every": 25}
"""The robust agent's observer gains and training perturbations (round 4's choice) and the table it keeps
(round 5's: the best-rehearsing of its tables every 25 episodes over the second half), chosen on
surrogates of design id seeds 90-92 only (``scripts/robust_design.py``; docs/decisions.md §Robust)."""

LEARNERS: dict[str, Callable[[], QConfig]] = {
    "paper": QConfig,
    "improved": improved_config,
    "robust": robust_config,
}
"""Learner designs: ``paper`` is §4 as printed; ``improved`` and ``robust`` are our extensions."""

SHAPINGS = ("away", "toward")
"""Readings of the paper's shaping term (docs/decisions.md §Shaping); kinds may pin one with ``@``."""

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
    shaping: str | None = None
    """Shaping reading pinned by the kind (``plm@away``); None = the run's ``--shaping``."""


def _kinds() -> dict[str, AgentKind]:
    surfaces = [(m.name, m.label) for m in MODEL_KINDS.values()]
    paper = [AgentKind(name, f"{label} (paper agent)", name, "paper") for name, label in surfaces]
    on_plant = [AgentKind("dyna-q", "Dyna-Q on the plant (paper agent)", PLANT, "paper", dyna=True),
                AgentKind(PLANT, "Q-learning on the true plant (reference)", PLANT, "paper")]
    everywhere = [*surfaces, (PLANT, "Q-learning on the true plant")]
    ours = [AgentKind(f"{name}+{design}", f"{label} ({design} agent)", name, design)
            for design in ("improved", "robust") for name, label in everywhere]
    readings = [AgentKind(f"{name}@{reading}", f"{label} (paper agent, shaping '{reading}')", name, "paper",
                          shaping=reading) for name, label in everywhere for reading in SHAPINGS]
    return {k.kind: k for k in (*paper, *on_plant, *ours, *readings)}


AGENT_KINDS: dict[str, AgentKind] = _kinds()
"""Every agent kind, in report order."""

DEFAULT_AGENTS: tuple[str, ...] = tuple(
    k for k in AGENT_KINDS if "@" not in k and k not in ("plant+improved", "plant+robust"))
"""What a run does unless ``--agents`` says otherwise: every surrogate under every design, and the
paper's on-plant baselines; the ``@`` readings and our agents on the true plant are opt-in."""

BENCH_AGENTS: tuple[str, ...] = ("glm", "plm", "nlarx-paper", "plm+improved", "plm+robust")
"""bench.py's default kinds: the paper's surrogate agents of Table 1 (GLM, PLM, NLARX) and our two agents
on its best surrogate. Every kind validates over DDS in lock-step, so each costs the graph what it costs
in-process many times over. Dyna-Q is one ``--agents`` away: its real steps at bench.py's token budget
(5 of the paper's 300 episodes) cost as many lock-step round trips as the five kinds' validations together,
for a row that is not the paper's Dyna-Q; the README's generated Table 1 has it at full budget. The full
matrix is ``msd-bench paper``'s default and ``--agents matrix`` here (docs/decisions.md §Main job)."""


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


MATRIX = "matrix"
"""``--agents matrix``: :data:`DEFAULT_AGENTS`, the full matrix (bench.py runs fewer by default)."""


def parse_agents(text: str) -> tuple[str, ...]:
    """``"plm, plm+improved"`` → ``("plm", "plm+improved")``, checked; ``matrix`` names every default kind."""
    agents: list[str] = []
    for name in (a.strip() for a in text.split(",") if a.strip()):
        agents += [k for k in DEFAULT_AGENTS if k not in agents] if name == MATRIX else [name]
    check_agents(agents)  # a kind named twice is a mistake; "matrix,plm+robust" adds to the matrix
    return tuple(agents)


def surrogates_of(agents: Sequence[str]) -> list[str]:
    """Registered model kinds that at least one of ``agents`` trains on, in registry order."""
    need = {agent_kind(a).surrogate for a in agents}
    return [m for m in MODEL_KINDS if m in need]


def learner_config(kind: str, episodes: int, steps: int, force: float, shaping: str = "away") -> QConfig:
    """The learner of agent kind ``kind`` at the given budget and force limit.

    ``shaping`` is the run's reading of the paper's shaping term; a kind that
    pins one (``plm@toward``) overrides it. Our agents keep their own.
    """
    k = agent_kind(kind)
    base = LEARNERS[k.agent]()
    if k.agent == "paper":
        base = replace(base, shaping=k.shaping or shaping)
    if k.surrogate == PLANT:  # a rehearsal on the plant would cost real samples: keep the final table
        base = replace(base, select_every=0)
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
