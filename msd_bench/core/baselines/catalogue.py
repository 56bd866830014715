"""The one table of classical baselines: a new baseline is a module of this package and a line here.

Each line names the module that holds the baseline's science and says how it
reads in reports. Why a table of its own, apart from
:mod:`msd_bench.core.baselines.designs`: listing and checking kinds must not
import the compiled modules (numba, python-control cost more than a second),
so the design registry (:mod:`msd_bench.designs.baselines`) reads this table
and the modules load only when a baseline is designed.

A baseline module offers one face: ``Options`` (a frozen dataclass of its
keyword options), ``design(model, target, force, dt, opt)`` returning a frozen
design with ``as_dict()``, ``rollout(plant, design, cond, noise)`` (the
compiled batch rollout with ``greedy_under``'s semantics) and ``Stepwise``
(built from a design: ``reset()``, ``act(y) -> force``).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, NamedTuple


class Listing(NamedTuple):
    """One baseline: its registry name, the module that makes it, and how it reads."""

    name: str
    """Registry name, the part after ``+`` in a kind (``glm+pid``)."""
    module: str
    """Module of this package with the baseline's face (see the module docstring); a dotted path for
    one elsewhere (a plug-in's)."""
    summary: str
    """One line for reports and docs."""
    label: str
    """Label in Table 1 rows."""
    fixed: Mapping[str, Any] = MappingProxyType({})
    """Options this listing pins (``pid-continuous`` is ``pid`` with any force in ±F)."""


CATALOGUE: tuple[Listing, ...] = (
    Listing("pid", "pid", "PID tuned at a phase margin and crossover on the linear model at the set-point, "
            "output the nearest of the 5 forces", "PID baseline", {"quantised": True}),
    Listing("pid-continuous", "pid", "the same PID, any force in ±F (what the 5-force actuator costs)",
            "continuous-force PID baseline", {"quantised": False}),
    Listing("lqr", "lqr", "LQR with integral action at the set-point, Kalman observer with force bias, "
            "5 forces", "LQR baseline"),
    Listing("mpc", "mpc", "finite-alphabet MPC over 1 s, move-blocked tree, Kalman observer with force bias",
            "MPC baseline"),
)
"""Every baseline, in report order."""
