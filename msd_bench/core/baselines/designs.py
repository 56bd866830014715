"""The common shape of the baseline designs: one table, one design call, one rollout.

A protocol that puts every controller (Q-learners and these) behind one face
needs, per design: ``design(model, target, force, dt, **options)`` returning a
frozen design with ``as_dict()``; a compiled batch rollout with
``greedy_under``'s semantics; and a stepwise controller (``reset()``,
``act(y) -> force``). :data:`DESIGNS` is that table; agent kinds are spelled
``<surrogate>+<design>`` (``glm+pid``, ``greybox+lqr``, ``plm+mpc``) and
:func:`parse_kind` splits them. Scoring under scenarios is not here: a baseline is a policy of
:mod:`msd_bench.designs.baselines`, scored by the one evaluator,
:func:`msd_bench.core.evaluation.robustness.evaluate_policy`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from typing import Any, NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.baselines.catalogue import CATALOGUE, Listing
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel

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
