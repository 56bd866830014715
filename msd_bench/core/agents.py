"""The agent kinds of Table 1: what each row's agent learns on and how it sees the state.

Kept apart from the pipeline (which imports torch and python-control) so the
command line can list and check kinds instantly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from msd_bench.core.errors import ConfigError

SURROGATES = ("glm", "plm", "nlarx-paper", "nlarx-improved")
"""Identified models an agent can train on."""


@dataclass(frozen=True)
class AgentKind:
    """One row of Table 1: what the agent learns on and how it sees the state."""

    kind: str
    """Machine name used in reports and on the command line."""
    label: str
    """Human label."""
    surrogate: str
    """``glm``, ``plm``, ``nlarx-paper``, ``nlarx-improved``, or ``plant`` (on-plant learners)."""
    agent: str
    """``paper`` (§4 as printed) or ``improved`` (our extension)."""
    dyna: bool = False
    """Dyna-Q with planning on the true plant (paper §3.4.2)."""


AGENT_KINDS: dict[str, AgentKind] = {
    k.kind: k
    for k in (
        AgentKind("glm", "GLM (paper agent)", "glm", "paper"),
        AgentKind("plm", "PLM (paper agent)", "plm", "paper"),
        AgentKind("nlarx-paper", "NLARX paper form (paper agent)", "nlarx-paper", "paper"),
        AgentKind("nlarx-improved", "NLARX improved form (paper agent)", "nlarx-improved", "paper"),
        AgentKind("dyna-q", "Dyna-Q on the plant (paper agent)", "plant", "paper", dyna=True),
        AgentKind("plant", "Q-learning on the true plant (reference)", "plant", "paper"),
        AgentKind("glm+improved", "GLM (improved agent)", "glm", "improved"),
        AgentKind("plm+improved", "PLM (improved agent)", "plm", "improved"),
        AgentKind("nlarx-paper+improved", "NLARX paper form (improved agent)", "nlarx-paper", "improved"),
        AgentKind("nlarx-improved+improved", "NLARX improved form (improved agent)", "nlarx-improved",
                  "improved"),
    )
}
PAPER_TABLE = ("glm", "plm", "nlarx-paper", "nlarx-improved", "dyna-q")
"""The paper's Table 1 rows (plus the improved NLARX form)."""


def check_agents(agents: Sequence[str]) -> None:
    """One-line ConfigError unless every kind is known and given once."""
    unknown = [a for a in agents if a not in AGENT_KINDS]
    if unknown:
        raise ConfigError(f"unknown agent kind {unknown[0]!r}; choose from {', '.join(AGENT_KINDS)}")
    if not agents or len(set(agents)) != len(agents):
        raise ConfigError(f"agent kinds must be given once each, got {list(agents)}")
