"""Rows of ``msd-bench rigs`` that are not an agent kind on an identified surrogate: one entry each.

Why a registry of its own: an agent kind is ``<model kind>+<design>`` and every
model kind is identified from records (:mod:`msd_bench.core.identification.model_kinds`),
so a model only a rig emulator can give — its own simulator — is no model kind:
registered there it would become a row of every command. A route names what
its policy is made on and which registered design makes it; an unknown route is
one :class:`~msd_bench.core.errors.ConfigError` line naming the known ones.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from msd_bench import designs
from msd_bench.core.errors import ConfigError
from msd_bench.designs import kinds

if TYPE_CHECKING:
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.rigs.population import RigSpec
    from msd_bench.designs import Drive, Policy, Settings


def _plant(spec: RigSpec) -> StepModel:
    from msd_bench.core.physics.model import plant_model

    return plant_model(spec.params)


def _true_drive(spec: RigSpec) -> Drive:
    imp = spec.imperfections
    return designs.Drive(imp.delay_samples, imp.actuator_tau)


def _truth(spec: RigSpec) -> StepModel:
    from msd_bench.core.rigs.truth import rig_model

    return rig_model(spec.params, spec.imperfections)


@dataclass(frozen=True)
class Route:
    """A row made on something other than an identified surrogate."""

    kind: str
    """The row's name in ``rigs.json``."""
    label: str
    """Its label in every table."""
    design_kind: str
    """The registered agent kind whose design makes it (its learner and budgets)."""
    model: Callable[[RigSpec], StepModel]
    """What the design is given to train on, from the rig's drawn specification."""
    model_note: str
    """What that model is, for the report."""
    drive: Callable[[RigSpec], Drive | None]
    """What the design is told of the drive (None: nothing)."""

    def make(self, spec: RigSpec, settings: Settings, seeds: Sequence[int]) -> Policy:
        """The route's policy on rig ``spec`` (one member per learning seed)."""
        return designs.make(self.design_kind, self.model(spec), settings, seeds, self.drive(spec))

    def facts(self) -> dict[str, Any]:
        """What ``rigs.json`` says of the route."""
        return {"kind": self.kind, "label": self.label, "design_kind": self.design_kind,
                "model": self.model_note}


ROUTES: dict[str, Route] = {r.kind: r for r in (
    Route("truth+robust", "Rig's own simulator (robust agent; the ceiling)", kinds.RIG_SIMULATOR, _truth,
          "the rig's drawn plant, friction, actuator lag and dead time as a greybox-rig model (its "
          "sensor is not modelled); the observer predicts through the model's own dead time, so it is "
          "told no further delay", lambda _spec: None),
    Route("truth-plant+robust", "Rig's true plant (robust agent told the true delay)", kinds.PLANT_SIMULATOR,
          _plant, "the rig's drawn plant (no friction, no drive) as the grey-box model's kernel, the "
          "robust agent told the rig's true dead time as the open-loop rows are told the measured one: "
          "what a perfect grey-box fit would give", _true_drive),
)}
"""Every route, by row name."""


def route(kind: str) -> Route:
    """The route ``kind``; a one-line ConfigError listing the known ones otherwise."""
    try:
        return ROUTES[kind]
    except KeyError:
        raise ConfigError(f"unknown rig route {kind!r}; choose from {', '.join(ROUTES)}") from None
