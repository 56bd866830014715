"""The method against a plant-like node that is not our emulator (``bench.py --plant-ns NS``).

Such a node (a rig, or the rig emulator) runs in real time, may have no
``reset``, and its true model is unknown to the bench. So, compared with a
run on the emulator:

* the kinds that learn on the emulator's own model (Q-learning on the true
  plant: ``plant``, ``plant+improved``, ``plant+robust`` and their ``@``
  readings) are left out — there is no true model to learn on;
* Dyna-Q trains on the node itself, in real time, with a small budget stated
  in the report (:data:`DEFAULTS` ``dyna_episodes``);
* robustness is validated on the node, and only for scenarios a rig can be
  given from outside: other set-points and an added force disturbance
  (:data:`HARDWARE_KEYS`); noise, delay or parameter changes are the rig's own
  and are never simulated on the emulator's model;
* lengths are the paper's, and the run's real-time duration is estimated up
  front (:func:`expected_seconds`).

Pure application logic (no ROS) so it is tested and reused without a graph.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from msd_bench.app import plan
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.scenarios import Scenario, parse
from msd_bench.core.identification.excitation import PrbsConfig
from msd_bench.core.identification.model_kinds import needs_bias_records
from msd_bench.core.rigs.scales import Scales
from msd_bench.designs import kinds

DEFAULT_AGENTS: tuple[str, ...] = kinds.PLANT_NS
"""Agent kinds of a ``--plant-ns`` run (:data:`msd_bench.designs.kinds.PLANT_NS`)."""

DEFAULT_SCENARIOS: tuple[str, ...] = ("setpoint=0.5", "disturbance=2@15")
"""Robustness scenarios validated on the node (one set-point, one added load), on the paper's plant."""


def default_scenarios(scales: Scales = Scales.DEFAULT) -> tuple[str, ...]:
    """:data:`DEFAULT_SCENARIOS` on a rig of ``scales``: the same set-point relative to the stroke and
    the same load relative to the force limit, at the same second (the ids are in the rig's units,
    as a user would write them); the defaults themselves on the paper's plant."""
    if scales.is_default:
        return DEFAULT_SCENARIOS
    return (f"setpoint={scales.metres(0.5):g}", f"disturbance={scales.newtons(2.0):g}@15")

DEFAULT_SCENARIO_KINDS: tuple[str, ...] = kinds.PLANT_NS_SCENARIO_KINDS
"""Kinds whose tables are also validated under :data:`DEFAULT_SCENARIOS` (each costs real time)."""

DEFAULTS: dict[str, Any] = {"seeds": 3, "dyna_episodes": 2, "val_samples": 4_000,
                            "agents": DEFAULT_AGENTS}
"""bench.py's defaults under ``--plant-ns`` (paper-sized records and validation episodes)."""

HARDWARE_KEYS = ("setpoint", "disturbance")
"""Scenario keys a real rig can be given from outside (the command carries the disturbance)."""

REST_ESTIMATE_S = 10.0
"""Assumed seconds of zero force before each experiment or episode (the default plant decays from
1 m to within the rest threshold in about 10 s: damping ratio 0.32 at 1.55 rad/s)."""
STARTUP_ESTIMATE_S = 5.0
"""Assumed seconds to start and match each recording's processes."""

QUICK_LOOK: tuple[str, ...] = (
    "--samples", "600", "--val-samples", "400", "--seeds", "2", "--episodes", "20",
    "--dyna-episodes", "1", "--steps", "300", "--validation-steps", "600", "--nlarx-scale", "0.05",
    "--agents", ",".join(kinds.QUICK_LOOK), "--node-scenarios", "setpoint=0.5",
    "--scenario-kinds", ",".join(kinds.QUICK_LOOK_SCENARIO_KINDS))
"""The short configuration of the README ("a quick look", a few minutes); the e2e test runs it. Its
kinds need no PLM, so only the two broad records are recorded."""


def is_emulator_kind(kind: str) -> bool:
    """Whether ``kind`` learns on the emulator's own model (Q-learning on the true plant, not Dyna-Q)."""
    return kinds.on_emulator(kind)


def split_kinds(agents: Sequence[str]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(kinds that run against a foreign node, kinds left out because they need the emulator's model)."""
    kept = tuple(a for a in agents if not is_emulator_kind(a))
    dropped = tuple(a for a in agents if is_emulator_kind(a))
    if not kept:
        raise ConfigError(f"every agent kind given ({', '.join(agents)}) needs the emulator's own model; "
                          f"against --plant-ns choose surrogate kinds or one that learns on the node "
                          f"({', '.join(kinds.on_node(kinds.matrix()))})")
    return kept, dropped


def left_out_note(dropped: Sequence[str]) -> str:
    """The one-line note the run prints and the report carries ('' when nothing was left out)."""
    if not dropped:
        return ""
    return (f"left out {', '.join(dropped)}: Q-learning on the true plant needs the emulator's own "
            f"model, which a foreign node does not have")


def hardware_scenario(text: str, scales: Scales = Scales.DEFAULT) -> Scenario:
    """A scenario a rig can be given from outside: only ``setpoint`` and ``disturbance`` keys (values in
    the units of the rig of ``scales``; a set-point outside its stroke is one line)."""
    sc = parse(text, scales)
    if sc.id == "nominal":
        raise ConfigError("the nominal condition is always validated; give set-point or disturbance "
                          "scenarios, e.g. setpoint=0.5 or disturbance=2@15")
    bad = [item.partition("=")[0].strip() for item in sc.id.split(",")
           if item.partition("=")[0].strip() not in HARDWARE_KEYS]
    if bad:
        raise ConfigError(f"scenario {sc.id!r}: {bad[0]} cannot be applied to a rig from outside; "
                          f"on --plant-ns only {' and '.join(HARDWARE_KEYS)} scenarios run")
    return sc


def check_node_scenarios(scenarios: Sequence[str], kinds: Sequence[str], episode_s: float,
                         scales: Scales = Scales.DEFAULT) -> None:
    """Every scenario is one a rig can be given; a disturbance must start within the episode.

    The timing is checked only when some kind of the run is validated under the scenarios
    (``kinds``): without one no episode runs under them (``--agents plm`` leaves the default
    ``disturbance=2@15`` unused), so a shortened ``--validation-steps`` is no mistake.
    """
    for text in scenarios:
        sc = hardware_scenario(text, scales)
        if kinds and sc.disturbance != 0.0 and sc.disturbance_time >= episode_s:
            raise ConfigError(f"scenario {sc.id!r}: the disturbance starts at {sc.disturbance_time:g} s, "
                              f"after the {episode_s:g} s validation episode ends; shorten its time or give "
                              f"other --node-scenarios")


@dataclass(frozen=True)
class Duration:
    """The real-time parts of a ``--plant-ns`` run, seconds (CPU-bound identification and training
    on the surrogates come on top and depend on the machine)."""

    record: float
    validation: float
    scenarios: float
    dyna: float

    @property
    def total(self) -> float:
        """All real-time parts."""
        return self.record + self.validation + self.scenarios + self.dyna

    def line(self) -> str:
        """One line for the start of the run and the README."""
        return (f"expected real-time duration about {self.total / 60:.0f} min: "
                f"record {self.record / 60:.1f}, "
                f"validation {self.validation / 60:.1f}, node scenarios {self.scenarios / 60:.1f}, "
                f"Dyna-Q training {self.dyna / 60:.1f} min (identification and surrogate training "
                f"are CPU time on top)")


def expected_seconds(*, samples: int, val_samples: int, agents: Sequence[str], seeds: int,
                     validation_steps: int, dyna_episodes: int, steps: int,
                     scenarios: Sequence[str], scenario_kinds: Sequence[str], dt: float = 0.01,
                     record: bool = True) -> Duration:
    """Real time a ``--plant-ns`` run spends on the node, from its sample counts.

    Every sample costs ``dt``; every experiment and episode starts with a rest
    (:data:`REST_ESTIMATE_S`) and every experiment with process start-up
    (:data:`STARTUP_ESTIMATE_S`).
    """
    rec = 0.0
    if record:
        from msd_bench.app.agents import surrogates_of

        specs = plan.paper_plan(0, samples, val_samples)
        if not needs_bias_records(surrogates_of(agents)):
            specs = [e for e in specs if e.bias is None]
        n = sum(e.signal.n_samples + (e.signal.settle if isinstance(e.signal, PrbsConfig) else 0)
                for e in specs)
        rec = n * dt + len(specs) * (REST_ESTIMATE_S + STARTUP_ESTIMATE_S)
    episode = validation_steps * dt + REST_ESTIMATE_S
    val = len(agents) * seeds * episode
    scen = len([k for k in scenario_kinds if k in agents]) * len(scenarios) * seeds * episode
    dyna = (seeds * dyna_episodes * (steps * dt + REST_ESTIMATE_S)
            if kinds.on_node(agents) else 0.0)
    return Duration(rec, val, scen, dyna)
