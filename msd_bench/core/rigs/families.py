"""The rig families: one entry per family, looked up by name everywhere (``rigs --family``, ``rig.py``).

Why a registry: a population is a documented distribution with its own design
and held-out seed ranges; a new family is one :class:`Family` entry here and
nothing else, and an unknown name is one line (with the nearest name) in every
command and node that takes one. Each family's ranges and why they are
realistic are in docs/rig-families.md.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass

from msd_bench.core.errors import ConfigError
from msd_bench.core.rigs import population, scaled_family, stage_family


@dataclass(frozen=True)
class Family:
    """A population of rigs: a rig per seed, and which seeds are for design and which are held out."""

    name: str
    """Machine name (``--family NAME``, ``-p family:=NAME``)."""
    summary: str
    """One line: what its rigs are."""
    draw: Callable[[int], population.RigSpec]
    """The rig of a seed (deterministic)."""
    design: range
    """Seeds of its design rigs: choose anything on these."""
    held_out: range
    """Seeds of its held-out rigs: report these, never tune on them (disjoint from ``design``)."""
    module: str
    """The module that draws it (recorded in results)."""
    not_in_process: str = ""
    """Why ``msd-bench rigs`` and ``efficiency`` cannot run its rigs yet ('' when they can); ``rig.py``
    serves every family's members."""

    def span(self) -> str:
        """Its design seeds as ``first-last``."""
        return f"{self.design.start}-{self.design.stop - 1}"


FAMILIES: dict[str, Family] = {
    "default": Family("default", "the default plant x0.8-1.25 with friction, delay, lag and sensor faults, "
                      "100 Hz on a 5 m stroke (docs/rig.md §Population)", population.draw,
                      population.DESIGN_RIGS, population.HELD_OUT_RIGS, population.__name__),
    "scaled": Family("scaled", "each default-family rig of the same seed in other length, mass and time "
                     "units (x0.05-20 each, log-uniform)", scaled_family.draw,
                     population.DESIGN_RIGS, population.HELD_OUT_RIGS, scaled_family.__name__),
    "stage": Family("stage", "linear positioning stages: 10-200 kg, 0.1-1 m, 50-1000 N, 500 Hz or 1 kHz, "
                    "Coulomb friction and an offset force, a weak spring at most", stage_family.draw,
                    population.DESIGN_RIGS, population.HELD_OUT_RIGS, stage_family.__name__,
                    not_in_process="its records are taken under its hold loop and its surrogates identified "
                    "as the held system's, which msd-bench rigs does not do yet (docs/rig-families.md "
                    "§stage); rig.py serves its members"),
}
"""Every rig family by name; ``default`` is today's population, bit for bit."""

DEFAULT_FAMILY = "default"


def family(name: object) -> Family:
    """The family called ``name``, or one ConfigError line naming the choices (and the nearest)."""
    if isinstance(name, str) and name in FAMILIES:
        return FAMILIES[name]
    near = difflib.get_close_matches(str(name), FAMILIES, n=1)
    hint = f" (did you mean {near[0]!r}?)" if near else ""
    raise ConfigError(f"unknown rig family {name!r}{hint}; families: {', '.join(FAMILIES)}")


def in_process(name: object) -> Family:
    """The family called ``name`` if ``msd-bench rigs`` can run its rigs; else one ConfigError line."""
    fam = family(name)
    if fam.not_in_process:
        raise ConfigError(f"rig family {fam.name!r} cannot run in-process yet: {fam.not_in_process}")
    return fam


def draw(name: str, seed: int) -> population.RigSpec:
    """Rig ``seed`` of family ``name``."""
    return family(name).draw(seed)
