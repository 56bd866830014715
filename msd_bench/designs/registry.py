"""The one registry of controller designs, and the agent kinds it generates.

Every kind of Table 1 is ``<surrogate>+<design>`` (bare ``plm`` stays the
paper agent; ``dyna-q`` and ``plant`` stay): each design says which kinds it
offers over the registered model kinds (:data:`msd_bench.core.identification.model_kinds.MODEL_KINDS`),
so a new model kind or a new design needs no edit elsewhere. An unknown kind or
design is one :class:`ConfigError` line listing the known ones.

Design modules are imported lazily (:data:`_BUILTIN`): listing and checking
kinds costs no numba compilation and no python-control.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification.model_kinds import MODEL_KINDS
from msd_bench.designs.protocol import Design, KindSpec

PLANT = "plant"
"""Surrogate name of the kinds that learn on the true plant itself."""

_BUILTIN: tuple[tuple[str, str], ...] = (
    ("msd_bench.designs.qlearning", "DESIGNS"),
    ("msd_bench.designs.baselines", "DESIGNS"),
    ("msd_bench.designs.deeprl", "DESIGNS"),
)
"""Modules whose ``DESIGNS`` tuple holds built-in designs, in report order."""


@dataclass(frozen=True)
class AgentKind:
    """One row of Table 1: which design makes it and what it is made on."""

    kind: str
    """Machine name used in reports and on the command line."""
    label: str
    """Human label."""
    surrogate: str
    """A registered model kind, or ``plant``."""
    agent: str
    """The design's registry name (``paper``, ``robust``, ``dyna-q``, ``pid``, ...)."""
    shaping: str | None = None
    """Shaping reading pinned by the kind (``plm@away``); None = the run's ``--shaping``."""

    @property
    def on_plant(self) -> bool:
        """It is made on the true plant (no identified model): once per run, not per id seed."""
        return self.surrogate == PLANT

    @property
    def design(self) -> Design:
        """The registry entry that makes it."""
        return design(self.agent)

    @property
    def spec(self) -> KindSpec:
        """What its design is told about it."""
        return KindSpec(self.kind, self.label, self.surrogate, self.shaping)


class _Registry(Mapping[str, Design]):
    """Designs by name; the built-ins load on first use, tests may :func:`register` more."""

    def __init__(self) -> None:
        self._designs: dict[str, Design] = {}
        self._loaded = False

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for module, attr in _BUILTIN:
                for d in getattr(importlib.import_module(module), attr):
                    self._designs.setdefault(d.name, d)

    def __getitem__(self, name: str) -> Design:
        self._load()
        return self._designs[name]

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(list(self._designs))

    def __len__(self) -> int:
        self._load()
        return len(self._designs)

    def add(self, d: Design) -> None:
        self._load()
        if d.name in self._designs:
            raise ConfigError(f"design {d.name!r} is registered already")
        self._designs[d.name] = d

    def remove(self, name: str) -> None:
        self._designs.pop(name, None)


DESIGNS = _Registry()
"""Every controller design by registry name."""


def design(name: str) -> Design:
    """The design ``name``; a one-line ConfigError listing the known ones otherwise."""
    try:
        return DESIGNS[name]
    except KeyError:
        raise ConfigError(f"unknown design {name!r}; choose from {', '.join(DESIGNS)}") from None


def surfaces() -> list[tuple[str, str]]:
    """The registered model kinds ``(name, label)`` a design may be made on."""
    return [(m.name, m.label) for m in MODEL_KINDS.values()]


class _Kinds(Mapping[str, AgentKind]):
    """Every agent kind, generated from the designs (regenerated when a design is registered)."""

    def __init__(self) -> None:
        self._kinds: dict[str, AgentKind] | None = None

    def _table(self) -> dict[str, AgentKind]:
        if self._kinds is None:
            table: dict[str, AgentKind] = {}
            for name in DESIGNS:
                for spec in DESIGNS[name].kinds(surfaces()):
                    table.setdefault(spec.kind, AgentKind(spec.kind, spec.label, spec.surrogate, name,
                                                          spec.shaping))
            self._kinds = table
        return self._kinds

    def __getitem__(self, kind: str) -> AgentKind:
        return self._table()[kind]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._table()))

    def __len__(self) -> int:
        return len(self._table())

    def refresh(self) -> None:
        self._kinds = None


AGENT_KINDS = _Kinds()
"""Every agent kind, in report order (designs in registry order, then each design's own order)."""


def register(d: Design) -> None:
    """Add a design (a plug-in, or a test's): its kinds appear everywhere at once."""
    DESIGNS.add(d)
    AGENT_KINDS.refresh()


def unregister(name: str) -> None:
    """Remove a design added by :func:`register` (tests clean up with it)."""
    DESIGNS.remove(name)
    AGENT_KINDS.refresh()


def agent_kind(name: str) -> AgentKind:
    """The agent kind ``name``; a one-line ConfigError listing the kinds otherwise."""
    try:
        return AGENT_KINDS[name]
    except KeyError:
        raise ConfigError(f"unknown agent kind {name!r}; choose from {', '.join(AGENT_KINDS)}") from None


def plus_kinds(name: str, label: str, everywhere: bool,
               surfaces_: Sequence[tuple[str, str]]) -> list[KindSpec]:
    """``<surrogate>+<name>`` over every surrogate (and ``plant+<name>`` if ``everywhere``)."""
    targets = [*surfaces_, *([(PLANT, "Q-learning on the true plant")] if everywhere else [])]
    return [KindSpec(f"{s}+{name}", f"{slabel} ({label})", s) for s, slabel in targets]
