"""The agent node: make a kind's policy through its design, then close the loop on the plant.

The node knows no design: it asks :mod:`msd_bench.designs` for the policy of
its kind, one of

* in-process (default, fast) on the model artifact (``model_path``): a
  Q-learner trains all seeds in one compiled call, a baseline is designed;
* over topics, for a design that learns step by step (:meth:`Design.stepwise`):
  over a surrogate node's topics in lock-step with ``via_ros`` (the same
  Q-tables bit for bit), or over the plant's when the kind is made on the plant
  and no model is given (Dyna-Q: real interactions there, planning in-process).

Then every member of the policy (one per seed; a deterministic baseline has
one) runs once on the plant topics through its stepwise controller (unit step,
3,000 steps): the set-point goes out on ``<plant_ns>/reference`` as each run
starts, each run is written as a bag (with that reference), scored (paper §5),
and the node writes the policy's artifact (``policy.json`` and the design's
files, e.g. ``qtables.npz``) and ``result.json`` under ``out_dir`` and exits.

Against a node without ``reset`` (``reset:=false``, a rig) every episode
starts by zero force until the position is still and from the rest position
measured then (:mod:`msd_bench.core.rigs.rest`). ``scenarios`` (set-points and added
force disturbances only, the ones a rig can be given from outside) are then
validated on the node too, each seed once per scenario; the disturbance is
added to the command the agent sends (so the node's saturation clips the sum).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Float64

from msd_bench import designs
from msd_bench.app.agents import SHAPINGS, agent_kind
from msd_bench.app.job import shared
from msd_bench.app.plant_ns import hardware_scenario
from msd_bench.app.scoring import metric_row
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.evaluation.results import per_seed_row
from msd_bench.core.evaluation.robustness import cell
from msd_bench.core.evaluation.scenarios import Scenario
from msd_bench.core.physics.model import StepModel, check_rate
from msd_bench.core.rigs.hold import HoldLoop
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.scales import Scales
from msd_bench.designs import Controller, Drive, Policy, Settings, Stepwise
from msd_bench.designs.kinds import facts_record, made_on_plant, stepwise_namespace, stepwise_training
from msd_bench.designs.protocol import StepwiseLearner, settings_from
from msd_bench.io.bags.bag_writer import write_experiment
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.nodes.episode_client import Episode, EpisodeClient
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import declare_config
from msd_msgs_py.contract import PLANT_NAMESPACE, REFERENCE
from msd_msgs_py.ros import float64, qos


@dataclass(frozen=True)
class AgentNodeConfig:
    """What the agent node trains on, how, and where it validates."""

    kind: str = "plm"
    """Agent kind (``plm``, ``plm+improved``, ``dyna-q``, ...): it fixes the learner and Dyna-Q."""
    model_path: str = ""
    """Surrogate model artifact (JSON) to train on; unused by ``dyna-q``."""
    seeds: tuple[int, ...] = (0,)
    """Learning seeds; one agent per seed."""
    episodes: int = field(default=shared("episodes"), metadata={"range": (1, 100_000)})
    """Training episodes per seed on a model (paper: 300)."""
    plant_episodes: int = field(default=shared("plant_episodes"), metadata={"range": (1, 100_000)})
    """Training episodes per seed of a kind that learns on the plant node itself (Dyna-Q, on-plant
    deep RL): every step a real sample (paper: 300)."""
    steps: int = field(default=shared("steps"), metadata={"range": (1, 1_000_000)})
    """Steps per training episode (paper: 3,000)."""
    via_ros: bool = False
    """Train over the surrogate node's topics (lock-step) instead of in-process."""
    surrogate_ns: str = "/surrogate"
    """Namespace of the surrogate node used when ``via_ros`` is set."""
    planning_steps: int = field(default=shared("planning_steps"), metadata={"range": (0, 10_000)})
    """Dyna-Q planning updates per real step (paper: 100)."""
    plant_ns: str = PLANT_NAMESPACE
    """Namespace of the plant the agent is validated on (and Dyna-Q interacts with)."""
    lockstep: bool = True
    """The plant runs in lock-step (else real-time at 100 Hz)."""
    target: float = shared("target")
    """Validation set-point, m (paper: unit step)."""
    validation_steps: int = field(default=shared("validation_steps"), metadata={"range": (1, 1_000_000)})
    """Closed-loop validation length (paper: 3,000)."""
    window: int = field(default=shared("window"), metadata={"range": (1, 1_000_000)})
    """Terminal window of the SSE, samples."""
    dt: float = field(default=shared("dt"), metadata={"range": (1e-4, 1.0)})
    """Sample time of the plant, s (for settling times)."""
    pace: float = field(default=1.0, metadata={"range": (1e-3, 1e3)})
    """The plant's time unit against the paper's (1: durations in seconds; docs/decisions.md §Scales)."""
    force: float = field(default=shared("force"), metadata={"range": (1e-3, 1e4)})
    """Force magnitude F of the action alphabet, N."""
    stroke: float = field(default=shared("stroke"), metadata={"range": (1e-6, 1e6)})
    """The plant's full travel, m: the learners' lengths are the paper's relative to it."""
    decision_samples: int = field(default=1, metadata={"range": (1, 10_000)})
    """Plant samples per decision: the agent decides every this many samples and holds its command
    in between (its design learns on the model held over them; docs/rig-description.md)."""
    shaping: str = shared("shaping")
    """Reading of the paper's shaping penalty for the paper agent: ``away`` or ``toward``."""
    out_dir: str = ""
    """Where qtables.npz, result.json and the validation bags go (required)."""
    reset: bool = True
    """The node has ``reset``; false (a rig): zero force until still before every episode."""
    rest_window: int = field(default=RestConfig.window, metadata={"range": (4, 10_000_000)})
    """Samples the stillness is judged over (:class:`msd_bench.core.rigs.rest.RestConfig`)."""
    rest_threshold: float = field(default=0.005, metadata={"range": (1e-6, 1e3)})
    """Largest position standard deviation at rest, m (:class:`msd_bench.core.rigs.rest.RestConfig`)."""
    rest_timeout: float = field(default=30.0, metadata={"range": (0.1, 3600.0)})
    """Seconds of zero force after which an episode starts even if the mass never looked still."""
    scenarios: str = ""
    """Scenarios validated on the node besides the nominal run, separated by ``;`` (a scenario has
    commas): ``setpoint=`` / ``disturbance=`` items only."""
    drive_delay: int = field(default=-1, metadata={"range": (-1, 100_000)})
    """Dead time of the plant's drive, samples, as its bags show it, told to the design (``-1``: told
    nothing; :attr:`msd_bench.designs.protocol.Request.drive`)."""
    drive_lag: float = field(default=0.0, metadata={"range": (0.0, 1e3)})
    """The drive's lag, s (with ``drive_delay``)."""
    hold_stiffness: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """The rig's stated hold loop (docs/rig-families.md §stage), N/m; 0 with ``hold_damping`` 0: none.
    Told to the design with the drive (``drive_delay`` >= 0), as ``msd-bench rigs`` tells it: the
    robust agent's commands then carry the loop's force at the set-point (docs/rigs.md §The robust
    agent on a held rig)."""
    hold_damping: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """The hold loop's damping, N·s/m."""
    hold_position: float = field(default=0.0, metadata={"range": (-1e6, 1e6)})
    """The position the hold loop holds, m."""
    match_timeout: float = field(default=120.0, metadata={"range": (0.1, 3600.0)})
    """Seconds an episode waits for its node to match before the run ends with one line. Why this
    long: a node that is still starting on a loaded machine (imports, discovery beside other DDS
    participants) took over 30 s to answer; a node that never comes is still one line."""
    pooled: bool = False
    """Lock-step only, in a served process: take the plant's (and surrogate's) endpoints from the
    process's pool, matched already by an earlier job (:mod:`msd_bench.nodes.endpoints`)."""

    def __post_init__(self) -> None:
        agent_kind(self.kind)  # one-line ConfigError naming the kinds
        if self.shaping not in SHAPINGS:
            raise ConfigError(f"shaping must be one of {', '.join(SHAPINGS)}, got {self.shaping!r}")
        if not self.out_dir:
            raise ConfigError("out_dir is required")
        if not self.seeds:
            raise ConfigError("seeds must not be empty")
        if not self.model_path and not made_on_plant(self.kind):
            raise ConfigError(f"model_path is required: {self.kind} is made on an identified model")
        if self.window > self.validation_steps:
            raise ConfigError("window must not exceed validation_steps")
        if self.lockstep and not self.reset:
            raise ConfigError("lock-step needs the node's reset; set lockstep:=false for a node without one")
        if self.pooled and not self.lockstep:
            raise ConfigError("pooled needs lockstep: a free-running node publishes between jobs")
        for text in self.scenario_ids:
            hardware_scenario(text, self.scales)

    @property
    def scenario_ids(self) -> list[str]:
        """The ``scenarios`` one by one."""
        return [t.strip() for t in self.scenarios.split(";") if t.strip()]

    @property
    def scales(self) -> Scales:
        """The factors from the paper's plant to the one this agent runs on (scenario values are in its
        units)."""
        return Scales.of(self.stroke, self.force, self.dt)

    def drive(self) -> Drive | None:
        """What the design is told of the drive (None: nothing)."""
        if self.drive_delay < 0:
            return None
        hold = HoldLoop.from_gains(self.hold_stiffness, self.hold_damping, self.hold_position)
        return Drive(self.drive_delay, self.drive_lag, hold=hold)

    def settings(self) -> Settings:
        """What the kind's design takes from this node's budgets (the fields its job set)."""
        return settings_from({f.name: getattr(self, f.name) for f in fields(self)})


class _Learn:
    """Episode controller adapter for a stepwise learner; ``on_start`` runs as its episode starts.

    With ``hold`` > 1 the learner decides every ``hold`` samples (its command held in between) and
    learns from the position at the next decision: the transitions it saw in-process on a held model.
    """

    def __init__(self, learner: StepwiseLearner, on_start: Callable[[], None] | None = None,
                 hold: int = 1) -> None:
        self.learner = learner
        self.on_start = on_start
        self.hold = hold
        self.k = 0
        self.u = 0.0

    def start(self, x0: float) -> None:
        if self.on_start is not None:
            self.on_start()
        self.k = 0
        self.learner.start_episode(x0)

    def act(self) -> float:
        if self.k % self.hold == 0:
            self.u = self.learner.act()
        return self.u

    def observe(self, x: float) -> None:
        self.k += 1
        if self.k % self.hold == 0:
            self.learner.learn(x)


class _Drive:
    """Episode controller adapter for a policy member's stepwise controller; announces its set-point.

    ``disturbance`` N are added to every command from step ``disturbance_step`` on: on a rig the
    load can only come through the command (the node's saturation then clips the sum).
    """

    def __init__(self, controller: Controller, target: float, announce: Callable[[float], None],
                 disturbance: float = 0.0, disturbance_step: int = 0, hold: int = 1) -> None:
        self.controller = controller
        self.target = target
        self.announce = announce
        self.y = 0.0
        self.k = 0
        self.u = 0.0
        self.disturbance = disturbance
        self.disturbance_step = disturbance_step
        self.hold = hold
        """Samples per decision: the controller is asked every ``hold`` samples, its command held between."""

    def start(self, x0: float) -> None:
        self.controller.reset()
        self.y = x0
        self.k = 0
        self.announce(self.target)

    def act(self) -> float:
        if self.k % self.hold == 0:
            self.u = self.controller.act(self.y)
        u = self.u
        return u + self.disturbance if self.k >= self.disturbance_step else u

    def observe(self, x: float) -> None:
        self.y = x
        self.k += 1


class AgentNode(Node):
    """Train, validate on the plant, write the results, finish (``done`` holds the exit status).

    Every callback of the node (its own and its episode client's) ends the node
    through ``done`` when it raises a :class:`MsdBenchError`: the process then
    prints that one line (:func:`msd_bench.nodes.spin.spin_node`) whichever
    executor dispatched the callback (the events executor would otherwise log
    the error and its stack before passing it on).
    """

    events_executor = True
    """One lock-step exchange per training step: run on the events executor (:mod:`.spin`)."""

    def __init__(self, config: AgentNodeConfig | None = None, **node_kwargs: Any) -> None:
        super().__init__("agent", **node_kwargs)
        self.config = config or declare_config(self, AgentNodeConfig, "agent")
        self.interface = declare_interface(self)
        """The plant's face (``plant_ns`` only; surrogates speak the msd face)."""
        if self.config.reset and self.interface.reset is None:
            raise ConfigError(f"the {self.interface.kind} interface has no reset: set reset:=false "
                              "(and lockstep:=false)")
        self.out = Path(self.config.out_dir)
        self.done: Future[int] = Future()
        self.policy: Policy | None = None
        """The trained or designed policy, once made."""
        self.per_seed: list[dict[str, Any]] = []
        self.model: StepModel | None = None
        self._training = "in-process"
        self.robust: dict[str, dict[str, list[float]]] = {}
        self.x0: dict[str, dict[int, float]] = {}
        self._client = EpisodeClient(
            self, lockstep=self.config.lockstep, reset=self.config.reset,
            rest=RestConfig(self.config.rest_window, self.config.rest_threshold, self.config.rest_timeout),
            interfaces={self.config.plant_ns: self.interface}, pooled=self.config.pooled,
            match_timeout_s=self.config.match_timeout)
        self._client.log = self._warn
        self._client.on_error = self._fail
        self._reference = self.create_publisher(
            Float64, REFERENCE.resolve(self.config.plant_ns), qos(REFERENCE))
        self._source = self._check_inputs()
        self._start_timer = self.create_timer(0.01, self._client.guarded_timer(self._start))

    def _fail(self, exc: MsdBenchError) -> None:
        """End the node with a user error (printed as one line by :func:`msd_bench.nodes.spin.spin_node`)."""
        if not self.done.done():
            self.done.set_exception(exc)

    def _warn(self, line: str) -> None:
        self.get_logger().warning(line)

    def _check_inputs(self) -> dict[str, str] | None:
        """Load the model up front so a bad path fails before any ROS traffic."""
        if not self.config.model_path:
            return None
        self.model = artifacts.load_model(Path(self.config.model_path))
        check_rate(self.model, self.config.dt, "the agent (parameter dt)")
        return artifacts.source(Path(self.config.model_path))

    def _start(self) -> None:
        """Make the policy in-process on the model, or train it over topics: the design says which
        (a design that learns step by step does so over the plant, or over a surrogate with ``via_ros``)."""
        self._start_timer.cancel()
        cfg = self.config
        over = None
        if cfg.via_ros or self.model is None:  # a design made in one go (a baseline) ignores via_ros
            over = designs.stepwise(cfg.kind, self.model, cfg.settings(), cfg.seeds, cfg.drive())
            if over is None and self.model is None:
                raise ConfigError(f"{cfg.kind} learns nothing over topics: give its model_path")
        if over is None:
            self._trained(designs.make(cfg.kind, self.model, cfg.settings(), cfg.seeds, cfg.drive()))
            return
        self._train_over(over, stepwise_namespace(over, cfg.plant_ns, cfg.surrogate_ns))

    def _train_over(self, over: Stepwise, ns: str) -> None:
        """Every learner's episodes over ``ns``'s topics, then the policy they made."""
        first = True
        for learner in over.learners:
            for _ in range(over.episodes):
                announce = functools.partial(self._first_step, ns) if first else None
                n = self.config.decision_samples  # over.steps counts decisions
                self._client.submit(Episode(_Learn(learner, announce, n), ns, over.steps * n))
                first = False
        self._training = stepwise_training(self.config.kind, over)
        self._client.on_idle = lambda: self._trained(over.finish())
        self.get_logger().info(f"training {len(over.learners)} seed(s) over {ns}")

    def _first_step(self, ns: str) -> None:
        """Log when the first training step goes out: discovery and matching are over (a benchmark times
        ROS training from this line, benchmarks/bench_lockstep.py)."""
        self.get_logger().info(f"first training episode under way over {ns}")

    def _trained(self, policy: Policy) -> None:
        """Save the policy's artifact, then validate every member on the plant (and each scenario)."""
        cfg = self.config
        self.policy = policy
        prov = artifacts.Provenance(
            tuple(s for s in [self._source] if s is not None), _jsonable_config(cfg), cfg.seeds[0])
        designs.save(policy, self.out, prov.as_dict(), root=self.out)
        members = range(len(policy.members))
        self.get_logger().info(f"trained; validating {len(members)} member(s) on {cfg.plant_ns}")
        for i in members:
            ctl = _Drive(policy.controller(i, cfg.target), cfg.target, self._announce,
                         hold=cfg.decision_samples)
            self._client.submit(Episode(ctl, cfg.plant_ns, cfg.validation_steps, record=True,
                                        on_done=functools.partial(self._validated, policy.members[i])))
        for text in cfg.scenario_ids:
            sc = hardware_scenario(text, cfg.scales)
            for i in members:
                ctl = _Drive(policy.controller(i, sc.setpoint), sc.setpoint, self._announce, sc.disturbance,
                             round(sc.disturbance_time / cfg.dt), hold=cfg.decision_samples)
                self._client.submit(Episode(ctl, cfg.plant_ns, cfg.validation_steps, record=True,
                                            on_done=functools.partial(self._scenario_done, sc,
                                                                      policy.members[i])))
        self._client.on_idle = self._finish

    def _announce(self, target: float) -> None:
        """Publish the validation set-point, so the graph (and a recorder) sees what the agent tracks."""
        self._reference.publish(float64(target))

    def _validated(self, seed: int, ep: Episode) -> None:
        cfg = self.config
        rows = np.array(sorted(ep.rows)[: cfg.validation_steps])
        t, x, v, u = rows[:, 0].astype(np.int64), rows[:, 1], rows[:, 2], rows[:, 3]
        params = {"role": "validation", "kind": cfg.kind, "seed": seed, "target": cfg.target}
        write_experiment(self.out / "validation" / f"seed_{seed}", t, u, x, v, params=params,
                         namespace=cfg.plant_ns, reference=cfg.target)
        metrics = metric_row(x, cfg.target, cfg.dt, cfg.window)
        self.per_seed.append(per_seed_row(seed, 0, metrics))
        self.x0.setdefault("nominal", {})[seed] = float(ep.x0 or 0.0)
        self.get_logger().info(f"seed {seed}: SSE {metrics['sse']:.2f} %  MAE {metrics['mae']:.3f} m")

    def _scenario_done(self, sc: Scenario, seed: int, ep: Episode) -> None:
        """One seed under one on-node scenario: a bag under ``scenarios/<id>/`` and its SSE and MAE."""
        cfg = self.config
        rows = np.array(sorted(ep.rows)[: cfg.validation_steps])
        t, x, v, u = rows[:, 0].astype(np.int64), rows[:, 1], rows[:, 2], rows[:, 3]
        params = {"role": "scenario", "kind": cfg.kind, "seed": seed, "scenario": sc.id,
                  "target": sc.setpoint}
        safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in sc.id)
        write_experiment(self.out / "scenarios" / safe / f"seed_{seed}", t, u, x, v, params=params,
                         namespace=cfg.plant_ns, reference=sc.setpoint)
        metrics = metric_row(x, sc.setpoint, cfg.dt, cfg.window)
        got = self.robust.setdefault(sc.id, {"sse": [], "mae": []})
        got["sse"].append(metrics["sse"])
        got["mae"].append(metrics["mae"])
        self.x0.setdefault(sc.id, {})[seed] = float(ep.x0 or 0.0)
        self.get_logger().info(f"seed {seed} under {sc.id}: SSE {metrics['sse']:.2f} %")

    def _finish(self) -> None:
        cfg = self.config
        facts = self.policy.facts if self.policy is not None else None
        drive = cfg.drive()
        doc = {"kind": cfg.kind, "agent": agent_kind(cfg.kind).agent, "config": _jsonable_config(cfg),
               "drive_told": None if drive is None else asdict(drive),  # what its design knew
               "training": self._training, **facts_record(facts),
               "per_seed": self.per_seed,
               "on_node_scenarios": {sid: cell(c["sse"], c["mae"]) for sid, c in self.robust.items()},
               "x0": {sid: {str(k): v for k, v in d.items()} for sid, d in self.x0.items()}}
        write_text_atomic(self.out / "result.json", json.dumps(artifacts.jsonable(doc), indent=1) + "\n",
                          root=self.out)  # atomic: a killed agent never leaves a torn result.json
        self.get_logger().info(f"agent done: {self.out / 'result.json'}")
        self.done.set_result(0)


def _jsonable_config(cfg: AgentNodeConfig) -> dict[str, Any]:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()}
