"""One run configuration for every way of running the method.

``msd-bench paper`` (in-process) and bench.py (node processes) both run a
:class:`RunConfig`; bench.py wraps it with what only a graph needs (run
directory, stages, real-time mode). Budgets default to the paper's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from msd_bench.app.agents import DEFAULT_AGENTS, SHAPINGS, check_agents, surrogates_of
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams, preset

if TYPE_CHECKING:  # the supervisor is compiled: loaded only when a run is validated behind it
    from msd_bench.core.rigs.hold import HoldLoop
    from msd_bench.core.safety.supervisor import Limits
from msd_bench.core.evaluation.scenarios import Scenario, suite
from msd_bench.core.physics.sensor import SensorModel
from msd_bench.core.rigs.description import RigDescription
from msd_bench.core.rigs.scales import Scales
from msd_bench.designs.kinds import split_by_model

_POSITIVE = ("seeds", "id_seeds", "episodes", "steps", "dyna_episodes", "samples", "val_samples",
             "validation_steps", "window")


@dataclass(frozen=True)
class RunConfig:
    """What one run of the method does (defaults = the paper's budgets)."""

    preset: str = "default"
    """Plant preset (``default`` or ``mild``; docs/design.md §Plant)."""
    seeds: int = 20
    """Learning seeds per identification seed and agent kind."""
    first_seed: int = 0
    """First learning seed; identification seed i uses first_seed + i·seeds … (never reused)."""
    id_seeds: int = 1
    """Identification seeds: each re-records and re-identifies every surrogate."""
    id_first_seed: int = 0
    """First identification seed; they are id_first_seed, id_first_seed + 1, …"""
    agents: tuple[str, ...] = DEFAULT_AGENTS
    """Agent kinds (rows) to run, from :data:`msd_bench.app.agents.AGENT_KINDS`."""
    shaping: str = "toward"
    """Reading of the paper's shaping term for the paper agent (docs/decisions.md §Shaping)."""
    episodes: int = 300
    """Training episodes per agent (paper: 300)."""
    steps: int = 3000
    """Steps per training episode (paper: 3,000)."""
    dyna_episodes: int = 300
    """Dyna-Q episodes on the true plant (paper: 300; each is 3,000 real interactions)."""
    planning_steps: int = 100
    """Dyna-Q planning updates per real step (paper: 100)."""
    samples: int = 12_000
    """Samples per identification record (paper: 12,000)."""
    val_samples: int = 4_000
    """Samples per validation record (separate seeds from the training records)."""
    validation_steps: int = 3000
    """Closed-loop validation length on the true plant (paper: 3,000)."""
    target: float = 1.0
    """Validation set-point, m (paper: unit step)."""
    window: int = 500
    """Terminal window of the SSE, samples (paper: not given)."""
    nlarx_scale: float = 1.0
    """Multiplies the NLARX training iterations (< 1 for smoke runs)."""
    record_noise: float = 0.0
    """Sensor noise σ on every identification record's measured position, m (issue: a real sensor)."""
    record_quant: float = 0.0
    """Sensor quantisation of the identification records, m (after the noise, as an ADC)."""
    scenarios: tuple[str, ...] = ()
    """Scenario ids evaluated besides the standard suite (:mod:`msd_bench.core.evaluation.scenarios`)."""
    supervisor: bool = False
    """Validate every run behind the safety supervisor (its default limits on the plant:
    docs/supervisor.md); off in-process, so the tables measure the controllers themselves."""
    rig: RigDescription | None = None
    """The rig the run is on (``--rig FILE``; None: the paper's plant). Its rate, stroke and force
    limit make the plant (:meth:`RigDescription.emulated_plant` of the preset) and the method's
    :class:`Scales`; set it with :meth:`on_rig`, which also scales the budgets."""

    def __post_init__(self) -> None:
        check_agents(self.agents)
        preset(self.preset)  # an unknown preset fails here, naming the choices
        if self.rig is not None:  # limits the emulated plant cannot take fail here, in one line
            half = self.plant.x_max
            if not abs(self.target) < half:
                raise ConfigError(f"set-point {self.target:g} m is outside the ±{half:g} m stroke of the rig")
        for name in _POSITIVE:
            if int(getattr(self, name)) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.first_seed < 0 or self.id_first_seed < 0:
            raise ConfigError("first_seed and id_first_seed must be >= 0")
        if self.planning_steps < 0:
            raise ConfigError(f"planning_steps must be >= 0, got {self.planning_steps}")
        if self.window > self.validation_steps:
            raise ConfigError("window must not exceed validation_steps")
        if not 0 < self.nlarx_scale <= 10:
            raise ConfigError(f"nlarx_scale must be in (0, 10], got {self.nlarx_scale}")
        self.scenario_suite()  # a malformed --scenario fails here, in one line
        SensorModel(self.record_noise, self.record_quant)  # likewise a bad sensor
        if not isinstance(self.supervisor, bool):
            raise ConfigError(f"supervisor must be true or false, got {self.supervisor!r}")
        if self.shaping not in SHAPINGS:
            raise ConfigError(f"shaping must be one of {', '.join(SHAPINGS)}, got {self.shaping!r}")

    def scenario_suite(self, scales: Scales | None = None) -> list[Scenario]:
        """The standard scenarios plus this run's extra ones, each once (on a rig of ``scales``,
        default the run's own: the standard ones scaled to it, the extra ones in its units)."""
        return suite(self.scenarios, self.scales if scales is None else scales)

    @property
    def decision_samples(self) -> int:
        """Rig samples per decision (the command held over them): the rig's, 1 on the paper's plant."""
        return 1 if self.rig is None else self.rig.samples_per_decision

    @property
    def hold(self) -> HoldLoop | None:
        """The hold loop the run's rig states (its drive adds it to every command), None on a bare rig."""
        return None if self.rig is None else self.rig.hold()

    @property
    def scales(self) -> Scales:
        """The factors from the paper's plant to the run's rig (:data:`Scales.DEFAULT` without one)."""
        return Scales.DEFAULT if self.rig is None else self.rig.scales()

    def on_rig(self, rig: RigDescription) -> RunConfig:
        """This run, its budgets given in paper samples and metres, on ``rig``: the plant and the
        scales are the rig's and the budgets last the same seconds (:meth:`scaled`). Applied once,
        to a run without a rig (a second application would scale the budgets twice)."""
        if self.rig is not None:
            raise ConfigError("the run is on a rig already")
        if rig.scales().is_default:  # config/rigs/default.yaml: the run as it is, bit for bit
            return self
        return replace(self, rig=rig, **self._scaled_fields(rig.scales()))

    def scaled(self, scales: Scales) -> RunConfig:
        """These budgets, stated in paper samples and metres, on a rig of ``scales``
        (docs/decisions.md §Scales): episodes, records, validation runs and the SSE window last the
        same seconds, the set-point is the same fraction of the stroke, the record sensor's noise
        and step scale with it. Itself on the paper's plant, bit for bit."""
        if scales.is_default:
            return self
        return replace(self, **self._scaled_fields(scales))

    def _scaled_fields(self, scales: Scales) -> dict[str, Any]:
        """The fields :meth:`scaled` changes, on a rig of ``scales``."""
        n = scales.samples
        return {"steps": n(self.steps), "samples": n(self.samples), "val_samples": n(self.val_samples),
                "validation_steps": n(self.validation_steps), "window": n(self.window),
                "target": scales.metres(self.target), "record_noise": scales.metres(self.record_noise),
                "record_quant": scales.metres(self.record_quant)}

    @property
    def sensor(self) -> SensorModel | None:
        """The sensor the identification records are measured through (None: the ideal one)."""
        sensor = SensorModel(self.record_noise, self.record_quant)
        return None if sensor.is_ideal else sensor

    @property
    def supervisor_limits(self) -> Limits | None:
        """The supervisor's limits on the plant when runs are validated behind it, else None."""
        from msd_bench.core.safety.supervisor import SupervisorOptions

        return SupervisorOptions().scaled(self.scales).limits(self.plant) if self.supervisor else None

    @property
    def plant(self) -> PlantParams:
        """The true plant's parameters: the preset's, on the rig's scales and rate when there is one."""
        p = preset(self.preset)
        return p if self.rig is None else self.rig.emulated_plant(p)

    def id_seed_values(self) -> list[int]:
        """The identification seeds of the run."""
        return list(range(self.id_first_seed, self.id_first_seed + self.id_seeds))

    def learning_seeds(self, id_index: int = 0) -> list[int]:
        """Learning seeds of the ``id_index``-th identification seed: disjoint across them."""
        start = self.first_seed + id_index * self.seeds
        return list(range(start, start + self.seeds))

    def surrogates_needed(self) -> list[str]:
        """Model kinds that at least one requested agent kind trains on."""
        return surrogates_of(self.agents)

    def surrogate_agents(self) -> list[str]:
        """Requested kinds that train on an identified model (one batch per identification seed)."""
        return split_by_model(self.agents)[0]

    def plant_agents(self) -> list[str]:
        """Requested kinds that learn on the true plant (once, not per identification seed)."""
        return split_by_model(self.agents)[1]
