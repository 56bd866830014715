"""The common shape of the baseline designs: one table, one design call, one rollout, one evaluation.

A protocol that puts every controller (Q-learners and these) behind one face
needs, per design: ``design(model, target, force, dt, **options)`` returning a
frozen design with ``as_dict()``; a compiled batch rollout with
``greedy_under``'s semantics; and a stepwise controller (``reset()``,
``act(y) -> force``). :data:`DESIGNS` is that table; agent kinds are spelled
``<surrogate>+<design>`` (``glm+pid``, ``greybox+lqr``, ``plm+mpc``) and
:func:`parse_kind` splits them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import fields, replace
from typing import Any, NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.baselines.catalogue import CATALOGUE, Listing
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.robustness import cell, conditions, sensor_noise
from msd_bench.core.evaluation.scenarios import Scenario, suite
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

FloatArray = NDArray[np.float64]


class Design(Protocol):
    """A baseline's frozen design (``PidDesign``, ``LqrDesign``, ...): what its artifact states."""

    def as_dict(self) -> dict[str, Any]:
        """Gains, margins, horizon, observer: everything ``policy.json`` records."""


class StepwiseLaw(Protocol):
    """The stepwise face an agent node drives."""

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``."""


class Entry(NamedTuple):
    """One baseline of :data:`~msd_bench.core.baselines.catalogue.CATALOGUE`, its module loaded."""

    design: Callable[..., Design]
    """``design(model, target, force, dt, **options)``."""
    controller: Callable[[Any], StepwiseLaw]
    """The stepwise form of a design."""
    rollout: Callable[[Kernel, Any, Conditions, FloatArray], tuple[FloatArray, FloatArray]]
    """The compiled batch rollout of a design on a plant kernel."""
    summary: str
    """One line for reports."""
    options: type
    """The design's options dataclass (its fields are the keyword options ``design`` accepts)."""
    fixed: Mapping[str, Any]
    """Options the listing pins (not the caller's to give)."""


def _entry(listing: Listing) -> Entry:
    """The listing's module behind one face (see :mod:`msd_bench.core.baselines.catalogue`)."""
    name = listing.module if "." in listing.module else f"msd_bench.core.baselines.{listing.module}"
    module = importlib.import_module(name)

    def make(model: StepModel, target: float, force: float, dt: float, **options: Any) -> Design:
        opt = replace(module.Options(**options), **listing.fixed)
        return cast(Design, module.design(model, target, force, dt, opt))

    return Entry(make, module.Stepwise, module.rollout, listing.summary, module.Options, listing.fixed)


DESIGNS: dict[str, Entry] = {listing.name: _entry(listing) for listing in CATALOGUE}
"""Every baseline design by name (the catalogue's order)."""


def entry(name: str) -> Entry:
    """The design called ``name``; a one-line error listing the known ones otherwise."""
    if name not in DESIGNS:
        raise ConfigError(f"unknown baseline design {name!r}; known: {', '.join(DESIGNS)}")
    return DESIGNS[name]


def parse_kind(kind: str) -> tuple[str, str]:
    """``"glm+pid"`` -> ``("glm", "pid")``; the design part must be a known design."""
    surrogate, sep, name = kind.rpartition("+")
    if not sep or not surrogate:
        raise ConfigError(f"baseline kind {kind!r} must be <surrogate>+<design>, "
                          f"e.g. glm+{next(iter(DESIGNS))}")
    entry(name)
    return surrogate, name


def make(name: str, model: StepModel, target: float, force: float, dt: float, **options: Any) -> Design:
    """Design ``name`` on ``model`` for ``target`` (deterministic); an unknown option is a one-line error."""
    e = entry(name)
    known = {f.name for f in fields(e.options)} - set(e.fixed)
    unknown = sorted(set(options) - known)
    if unknown:
        raise ConfigError(f"baseline {name}: unknown option(s) {', '.join(unknown)}; known: "
                          f"{', '.join(sorted(known))}")
    return e.design(model, target, force, dt, **options)


def rollouts(name: str, d: Design, nominal: PlantParams, sc: Scenario, seeds: Sequence[int],
             steps: int) -> tuple[FloatArray, FloatArray]:
    """True positions and commands under ``sc``: one run per noise draw, one run without a sensor.

    A deterministic design on one model has one run per condition; only sensor
    noise draws (one per seed, as the Q-learners' cells draw them) make more.
    """
    draws = list(seeds) if sc.has_sensor and sc.noise > 0.0 else list(seeds)[:1]
    plant = sc.plant(nominal)
    noise = sensor_noise(sc, draws, steps)
    return entry(name).rollout(plant_model(plant).kernel, d, conditions(sc, plant.dt), noise)


def evaluate(name: str, model: StepModel, nominal: PlantParams, seeds: Sequence[int],
             scenarios: Sequence[Scenario] | None = None, steps: int = 3000, window: int = 500,
             **options: Any) -> dict[str, dict[str, Any]]:
    """Per scenario id, the cell of :func:`robustness.cell`, designing once per set-point."""
    designs: dict[float, Design] = {}
    out: dict[str, dict[str, Any]] = {}
    for sc in scenarios if scenarios is not None else suite():
        if sc.setpoint not in designs:
            designs[sc.setpoint] = make(name, model, sc.setpoint, nominal.F, nominal.dt, **options)
        xs, _ = rollouts(name, designs[sc.setpoint], nominal, sc, seeds, steps)
        m = [compute(x, sc.setpoint, nominal.dt, window) for x in xs]
        out[sc.id] = cell([r.sse for r in m], [r.mae for r in m])
    return out
