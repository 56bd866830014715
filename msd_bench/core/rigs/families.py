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
    held: bool = False
    """Its rigs are recorded and run under their stated hold loop
    (:class:`~msd_bench.core.rigs.hold.HoldLoop`): ``msd-bench rigs`` runs them without the ceiling,
    refinement and the supervisor, and ``efficiency`` not yet (:func:`in_process`)."""

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
                    population.DESIGN_RIGS, population.HELD_OUT_RIGS, stage_family.__name__, held=True),
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


def in_process(name: object, ceiling: bool = False, refine: int = 0, supervisor: bool = False,
               curve: bool = False) -> Family:
    """The family called ``name`` if an in-process run of it can do what is asked; else one ConfigError
    line. A held family (a stage's) runs under its hold loop, which the ceiling's simulators, the
    refits from closed-loop records, the supervisor's nominal model and the efficiency curve's
    bill do not model yet (docs/rig-families.md §stage)."""
    fam = family(name)
    if not fam.held:
        return fam
    wanted = (("--ceiling", ceiling), ("--refine", refine), ("--supervisor on", supervisor),
              ("the efficiency curve", curve))
    asked = [what for what, on in wanted if on]
    if asked:
        raise ConfigError(f"rig family {fam.name!r} runs under its hold loop: {', '.join(asked)} "
                          f"{'is' if len(asked) == 1 else 'are'} not built for held rigs yet "
                          f"(docs/rig-families.md §stage)")
    return fam


def draw(name: str, seed: int) -> population.RigSpec:
    """Rig ``seed`` of family ``name``."""
    return family(name).draw(seed)
