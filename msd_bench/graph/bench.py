"""The main job on the emulated bench: every stage runs through real node processes.

Stages (``--stages`` picks a subset; each reads what the previous wrote under
the run directory, so a run can be resumed or re-reported):

``record``   plant (lock-step or real-time) + one served recorder and one served
             excitation process write one bag per experiment under ``excitation/``;
``identify`` the identifier process fits GLM / PLM / NLARX from those bags
             into ``models/`` (or from ``--bags DIR``);
``agents``   one agent node per agent kind, all in one served process, trains
             (in-process on the model artifact by default, over a surrogate
             node with ``--via-ros``, or Dyna-Q against the plant node) and
             validates every seed on the plant topics, writing
             ``agents/<kind>/`` (Q-tables, bags, result); Dyna-Q needs no
             model, so it is submitted before ``identify`` and runs beside it
             (:func:`start_model_free`);
``report``   Table 1 (Markdown, CSV, JSON) and the figures under ``report/``.

With ``--refine R`` (and ``plant_ns``) the agents are then refined on the node
after the agents stage, before the report (:mod:`msd_bench.graph.refine`:
``refine/``, ``report/refine.md``).

With ``plant_ns`` (``--plant-ns NS``) no emulator is started: every stage runs
against whatever node serves NS, in real time, without ``reset`` (zero force
until still before each experiment and episode), and only with the kinds and
scenarios that make sense on a node whose model is unknown
(:mod:`msd_bench.app.plant_ns`; docs/plant-ns.md).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.job import hold_params, job_document
from msd_bench.app.plant_ns import check_node_scenarios
from msd_bench.app.serve_protocol import EventError
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.identification.model_kinds import needs_bias_records
from msd_bench.designs import kinds
from msd_bench.graph import live
from msd_bench.graph import refine as refine_stage
from msd_bench.graph.jobs import JOBS_DIR, Job, JobFiles, JobServer, last_line
from msd_bench.graph.launch import LaunchError, NodeProcess, ProcessSet
from msd_bench.graph.record import ExperimentSpec, RecordServers, paper_plan, record_experiments
from msd_bench.graph.supervise import Supervision, agent_remaps
from msd_bench.graph.supervise import check as check_supervision
from msd_bench.io.bags.drive_file import read_drive
from msd_bench.io.storage.atomic import TEMP_PREFIX, write_text_atomic
from msd_bench.io.storage.paths import OutputError, writable_dir
from msd_msgs_py.contract import PLANT_NAMESPACE, surrogate_namespace
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface

STAGES = ("record", "identify", "agents", "report")


class StageError(MsdBenchError):
    """A stage's process failed; the message names it and quotes its last output line."""


@dataclass(frozen=True)
class BenchConfig:
    """One run of ``launch_scripts/bench.py``: the application's run plus what a graph needs."""

    run_dir: Path
    """Everything of the run goes here (``bags/<run-id>`` by default)."""
    run: RunConfig = field(default_factory=RunConfig)
    """The method's configuration (one identification seed: bench.py records once)."""
    realtime: bool = False
    """Run the plant at true 100 Hz instead of lock-step."""
    via_ros: bool = False
    """Train agents over surrogate nodes' topics instead of in-process."""
    bags: Path | None = None
    """Identify from these existing experiment bags instead of recording."""
    stages: tuple[str, ...] = STAGES
    """Stages to run."""
    plant_ns: str | None = None
    """Run against the node serving this namespace (no emulator started, real time, no reset)."""
    node_scenarios: tuple[str, ...] = ()
    """With ``plant_ns``: set-point / disturbance scenarios validated on the node."""
    scenario_kinds: tuple[str, ...] = ()
    """With ``plant_ns``: the agent kinds validated under ``node_scenarios`` too."""
    left_out: tuple[str, ...] = ()
    """With ``plant_ns``: requested kinds left out because they need the emulator's own model."""
    interface: PlantInterface = MSD_INTERFACE
    """With ``plant_ns``: the node's face (``--interface ros2_control ...``), handed to every node
    that talks to it (docs/ros2-control.md §Parameters)."""
    live_port: int | None = None
    """Serve the live view on this port of 127.0.0.1 (``--live [PORT]``, 0: a free one; None: off)."""
    live_wait_s: float = 0.0
    """With ``live_port``: wait up to this long for a viewer to subscribe before the first stage
    (``--live-wait``), so a short emulated run is not over before Foxglove has connected."""
    supervision: Supervision = field(default_factory=Supervision)
    """Which stages run behind the safety supervisor, with which options (docs/supervisor.md)."""
    refine: int = 0
    """``--refine R``: after the agents stage, each refinable kind refined on the node, up to R rounds
    (:mod:`msd_bench.graph.refine`; 0: none)."""
    refine_weight: int = 1
    """``--refine-weight``: how many times each closed-loop record counts in a refit."""
    rig: dict[str, object] | None = None
    """With ``--rig FILE``: the rate, stroke, force limit and face the run ran with (run.json)."""
    rig_file: Path | None = None
    """With ``--rig FILE``: the file, handed to the emulated plant and the supervisor as their
    ``--params-file`` (they take the rig's plant from it)."""
    timings: dict[str, float] = field(default_factory=dict, compare=False)
    """Seconds per stage, filled in as the run goes."""

    def __post_init__(self) -> None:
        unknown = [s for s in self.stages if s not in STAGES]
        if unknown:
            raise ConfigError(f"unknown stage {unknown[0]!r}; choose from {', '.join(STAGES)}")
        if self.run.id_seeds != 1:
            raise ConfigError("bench.py records one identification seed; use msd-bench paper for --id-seeds")
        check_supervision(self)
        refine_stage.check(self.refine, self.refine_weight, self.plant_ns, self.run.agents, self.stages)
        if self.plant_ns is None:
            if self.node_scenarios or self.scenario_kinds:
                raise ConfigError("--node-scenarios and --scenario-kinds need --plant-ns")
            if self.interface != MSD_INTERFACE:
                raise ConfigError(f"--interface {self.interface.kind} needs --plant-ns (the emulator "
                                  "speaks the msd face)")
            return
        if not self.plant_ns.startswith("/") or self.plant_ns == "/":
            raise ConfigError(f"--plant-ns must be an absolute namespace like /rig, got {self.plant_ns!r}")
        if self.via_ros:
            raise ConfigError("--via-ros trains over surrogate nodes of the emulator; it does not go with "
                              "--plant-ns")
        if not self.realtime:
            raise ConfigError("--plant-ns runs in real time")
        check_node_scenarios(self.node_scenarios, self.scenario_kinds,
                             self.run.validation_steps * self.run.plant.dt, self.run.scales)
        stray = [k for k in self.scenario_kinds if k not in self.run.agents]
        if stray:
            raise ConfigError(f"--scenario-kinds {stray[0]!r} is not among the run's agent kinds")

    @property
    def namespace(self) -> str:
        """The plant-like node's namespace: ``plant_ns`` or the emulator's ``/msd``."""
        return self.plant_ns or PLANT_NAMESPACE

    @property
    def seeds(self) -> list[int]:
        """Learning seeds of every agent kind."""
        return self.run.learning_seeds(0)

    @property
    def id_seed(self) -> int:
        """The identification seed: it picks the excitation plan's seeds."""
        return self.run.id_first_seed

    @property
    def excitation_dir(self) -> Path:
        """Where the experiment bags are (recorded here, or given with --bags)."""
        return self.bags if self.bags is not None else self.run_dir / "excitation"


Say = Callable[[str], None]


BENCH_DUPLICATE_CHECK_S = 1.0
"""Seconds the run's plant listens for a rival plant before serving (the node's default is 4 s, all of
it start-up the whole run waits for). The run's domain is one no other msd-bench run holds
(:mod:`msd_bench.graph.domains`), and a rival that discovery reveals later still stops one of the two at
the next claim heartbeat, which fails the stage with the conflict's one line."""


def plant_args(cfg: BenchConfig, sensor: bool = False) -> list[str]:
    """ROS arguments of the emulated plant process; ``sensor``: measured through the run's sensor.

    The sensor (``--record-noise``/``--record-quant``) is for the identification
    records only, as in ``msd-bench paper``: agents are validated on the ideal
    plant. Its noise is seeded by the identification seed, so two identification
    seeds see different noise and one seed the same noise run after run.
    """
    args = ["-p", f"preset:={cfg.run.preset}", "-p", f"lockstep:={str(not cfg.realtime).lower()}",
            "-p", f"duplicate_check:={BENCH_DUPLICATE_CHECK_S!r}", *rig_file_args(cfg)]
    if sensor and cfg.run.sensor is not None:
        args += ["-p", f"sensor_noise:={float(cfg.run.record_noise)!r}",
                 "-p", f"sensor_quant:={float(cfg.run.record_quant)!r}", "-p", f"sensor_seed:={cfg.id_seed}"]
    return args


def rig_file_args(cfg: BenchConfig) -> list[str]:
    """``--params-file FILE`` for a node that serves or guards the plant when the run has ``--rig``."""
    return [] if cfg.rig_file is None else ["--params-file", str(cfg.rig_file)]


def start_plant(procs: ProcessSet, cfg: BenchConfig, sensor: bool = False) -> NodeProcess:
    """Start the plant (with the run's sensor if ``sensor``) and wait until it says it is ready."""
    proc = procs.start("plant.py", plant_args(cfg, sensor), name="plant")
    proc.wait_for_line(r"ready \(", timeout=60.0)
    return proc


def record_plan(cfg: BenchConfig) -> list[ExperimentSpec]:
    """The paper's experiments the run's surrogates use.

    The ten bias PRBS records (training and validation) are only for models
    fitted on bias records (the PLM); a run without one records the two broad
    records alone, a sixth of the recording time.
    """
    specs = paper_plan(cfg.id_seed, cfg.run.samples, cfg.run.val_samples, cfg.run.scales)
    if needs_bias_records(cfg.run.surrogates_needed()):
        return specs
    return [s for s in specs if s.params.get("bias") is None]


def stage_record(cfg: BenchConfig, procs: ProcessSet, bar: Callable[[int, int, str], None],
                 servers: RecordServers | None = None) -> list[Path]:
    """Record the run's experiments through the recorder and excitation processes (and its sensor)."""
    return record_experiments(record_plan(cfg), cfg.excitation_dir, procs, cfg.namespace, not cfg.realtime,
                              bar, jobs=JobFiles(cfg.run_dir), run=cfg.run,
                              truth=cfg.run.sensor is not None, rest=cfg.plant_ns is not None,
                              iface=cfg.interface, servers=servers)


IDENTIFIER = "identifier"
"""The identifier node's name: its result events carry it (``identifier_node.NODE_NAME``)."""
SAVED_EVENT = "model_saved"
"""The identifier's event for each model it has written (``identifier_node.SAVED_EVENT``)."""
IDENTIFIED_EVENT = "identified"
"""The identifier's event once every model and fits.json are written."""


def stage_identify(cfg: BenchConfig, procs: ProcessSet, on_saved: Callable[[str], None] | None = None,
                   server: JobServer | None = None) -> dict[str, Any]:
    """Fit the surrogates from the bags in the identifier process (``server`` if the caller launched
    it early, so its imports overlapped the recording); ``on_saved`` hears of each model as soon as
    the identifier has written it (its agents can start while the rest are fitted)."""
    args = job_args(cfg, "identifier", identifier_job(cfg))
    server = (server or JobServer(procs, "identifier.py", "identifier")).ready()
    job = server.submit(args, name="identifier")
    # a rig's run has cost real time already: a slow machine must not lose it to a timeout here
    deadline = time.monotonic() + (600.0 if cfg.plant_ns is None else 3600.0)
    if on_saved is not None:
        _follow_saved(job, on_saved, deadline)
    try:
        status = job.wait(max(0.1, deadline - time.monotonic()))
    except LaunchError as err:
        raise StageError(f"{err}: {last_line(job.lines) or 'no output'}") from None
    server.close()
    from msd_bench.graph.run_files import read_json_object  # bounded: fits.json is a file like any other

    if status != 0 and not failed_models(cfg):  # some kinds failing alone: the others are written
        raise StageError(f"{job.name} failed (exit {status}): {last_line(job.lines) or 'no output'}")
    if status == 0:
        _check_identified(job)
    return read_json_object(cfg.run_dir / "models" / "fits.json")


def failed_models(cfg: BenchConfig) -> dict[str, str]:
    """The model kinds the identifier could not fit, with their reasons (``fits.json``): their
    agents are not run, and Table 1 reports them as failed with that reason."""
    from msd_bench.graph.run_files import read_failed_fits

    return read_failed_fits(cfg.run_dir / "models" / "fits.json")


def unmade_agents(cfg: BenchConfig) -> dict[str, str]:
    """Per agent kind whose model could not be fitted, why (one line)."""
    failed = failed_models(cfg)
    models = {k: agent_kind(k).surrogate for k in cfg.run.agents}
    return {k: f"its model {m} could not be identified: {failed[m]}"
            for k, m in models.items() if m in failed}


def agent_placement(cfg: BenchConfig, kind: str) -> dict[str, Any]:
    """Where and how the agent node of ``kind`` runs: what only the graph knows (the run's budgets
    come from :func:`msd_bench.app.job.job_document`)."""
    place: dict[str, Any] = {
        "kind": kind, "seeds": list(cfg.seeds), "out_dir": str(cfg.run_dir / "agents" / kind),
        "lockstep": not cfg.realtime, "plant_ns": cfg.namespace,
        "pooled": not cfg.realtime and not cfg.supervision.validation}  # a pooled endpoint is not remapped
    if cfg.plant_ns is not None:
        place["reset"] = False
        drive = read_drive(cfg.run_dir / "models")  # what the node's own bags show (identifier_node)
        if drive is not None:  # the hold loop is told with the drive, as msd-bench rigs tells it
            place["drive_delay"], place["drive_lag"] = drive
            place.update(hold_params(cfg.run))
        if kind in cfg.scenario_kinds and cfg.node_scenarios:
            place["scenarios"] = ";".join(cfg.node_scenarios)
    model = kinds.model_file(kind)  # on-plant Q-learning: "plant", the plant's own model
    if model is None:
        return place
    place["model_path"] = str(cfg.run_dir / "models" / (model + ".json"))
    if cfg.via_ros and kinds.trains_via_surrogate_node(kind):
        place.update(via_ros=True, surrogate_ns=surrogate_namespace(model))
    return place


def agent_job(cfg: BenchConfig, kind: str) -> dict[str, Any]:
    """The job document of the agent node of ``kind`` (the node derives its learner from ``kind``)."""
    return job_document("agent", cfg.run, agent_placement(cfg, kind))


def identifier_job(cfg: BenchConfig) -> dict[str, Any]:
    """The job document of the identifier node."""
    placement = {"bags_dir": str(cfg.excitation_dir), "out_dir": str(cfg.run_dir / "models"),
                 "namespace": cfg.namespace}
    return job_document("identifier", cfg.run, placement, seed=cfg.id_seed)


def write_job(cfg: BenchConfig, name: str, doc: dict[str, Any]) -> Path:
    """Write job ``doc`` atomically as ``jobs/<name>.json`` in the run directory; its path."""
    return JobFiles(cfg.run_dir).write(name, doc)


def job_args(cfg: BenchConfig, name: str, doc: dict[str, Any]) -> list[str]:
    """ROS arguments handing a node its job: the job file's path, and the plant's face."""
    return [*JobFiles(cfg.run_dir).args(name, doc), *cfg.interface.ros_args()]


def agent_args(cfg: BenchConfig, kind: str) -> list[str]:
    """ROS arguments of the agent process of one agent kind (its job file, written now)."""
    return [*job_args(cfg, f"agent-{kind}", agent_job(cfg, kind)), *agent_remaps(cfg)]


def surrogate_job(cfg: BenchConfig, name: str) -> dict[str, Any]:
    """The job document of the surrogate node serving model ``name`` (its ``dt`` and ``force_limit``
    are the run's plant's, from :func:`msd_bench.app.job.job_document`)."""
    placement = {"model_path": str(cfg.run_dir / "models" / (name + ".json")), "lockstep": True}
    return job_document("surrogate", cfg.run, placement)


def surrogate_args(cfg: BenchConfig, name: str) -> list[str]:
    """ROS arguments of the surrogate process serving model ``name`` for ``--via-ros`` training.

    Lock-step beside the lock-step plant; it leaves ``/clock`` to the plant
    (``publish_clock`` defaults to false for surrogates): one owner of sim time.
    """
    return [*JobFiles(cfg.run_dir).args(f"surrogate-{name}", surrogate_job(cfg, name)),
            "-r", f"__ns:={surrogate_namespace(name)}"]


def model_free_kinds(cfg: BenchConfig) -> list[str]:
    """The run's kinds that need no identified model (Dyna-Q learns on the plant itself)."""
    return kinds.on_node(cfg.run.agents)


def start_model_free(cfg: BenchConfig, server: JobServer) -> dict[str, Job]:
    """Submit the model-free kinds now, so they run on the idle plant while identification runs.

    Why: the identifier is one process of CPU work and Dyna-Q's real steps are a
    lock-step exchange with the plant; on two cores they overlap instead of
    queueing (issue: stages that overlap where the cores allow). The served agent
    process runs its jobs in order, so the kinds submitted later wait behind these.
    """
    server.ready()
    kinds = model_free_kinds(cfg)
    return {kind: server.submit(agent_args(cfg, kind), name=f"agent-{kind}") for kind in kinds}


def pipelined(cfg: BenchConfig, sensor: bool) -> bool:
    """Whether agents start as soon as their surrogate is identified, beside the identification.

    Only in lock-step, where a validation waits for the plant's answers instead
    of a clock (CPU taken by the identifier slows it, never spoils it), with
    training in-process (``--via-ros`` needs every surrogate node up first) and
    the plant that will validate already running (a sensor run restarts it).
    """
    return not (cfg.realtime or cfg.via_ros or sensor)


def start_agents_on(cfg: BenchConfig, server: JobServer, model: str,
                    started: dict[str, Job]) -> dict[str, Job]:
    """Submit the run's kinds that train on ``model`` (just identified) and are not submitted yet.

    Why: an agent job's validation is a lock-step exchange with the plant and
    the identifier is CPU work; on two cores they overlap instead of queueing.
    The served agent process runs its jobs in order; :func:`stage_agents`
    collects them in report order with the rest.
    """
    kinds = [k for k in cfg.run.agents if agent_kind(k).surrogate == model and k not in started]
    return {k: server.submit(agent_args(cfg, k), name=f"agent-{k}") for k in kinds}


def agent_starter(cfg: BenchConfig, server: JobServer, started: dict[str, Job],
                  say: Say) -> Callable[[str], None]:
    """The identifier's ``on_saved``: submit each newly identified model's kinds into ``started``."""
    def on_saved(name: str) -> None:
        new = start_agents_on(cfg, server, name, started)
        started.update(new)
        if new:
            say(f"  {name} identified: {', '.join(new)} start on the plant")
    return on_saved


def stage_agents(cfg: BenchConfig, procs: ProcessSet, say: Say, bar: Callable[[int, int, str], None],
                 server: JobServer | None = None, started: dict[str, Job] | None = None) -> None:
    """Every agent kind, one after another (they share the plant), as nodes of one served process
    (``server`` if the caller launched it early, so its start-up overlapped identification).
    ``started``: kinds already submitted to ``server`` (:func:`start_model_free`); their results are
    collected in report order like the rest."""
    unmade = unmade_agents(cfg)
    if cfg.via_ros:
        for name in [n for n in cfg.run.surrogates_needed() if n not in failed_models(cfg)]:
            p = procs.start("surrogate.py", surrogate_args(cfg, name), name=f"surrogate-{name}")
            p.wait_for_line(r"ready \(", timeout=60.0)
    agents = cfg.run.agents
    server = (server or JobServer(procs, "agent.py", "agent")).ready()  # one process, one node per kind
    started = started or {}
    for i, kind in enumerate(agents):
        bar(i, len(agents), kind)
        if kind in unmade:
            say(f"agent {kind} not run: {unmade[kind]}")
            continue
        job = started.get(kind) or server.submit(agent_args(cfg, kind), name=f"agent-{kind}")
        status = job.wait(3600.0 if cfg.plant_ns is None else 4 * 3600.0)
        if status != 0:
            raise StageError(f"{job.name} failed (exit {status}): {last_line(job.lines) or 'no output'}")
        say(f"agent done: {_agent_result(cfg, job, kind)}")
    server.close()
    bar(len(agents), len(agents), "done")


def _agent_result(cfg: BenchConfig, job: Job, kind: str) -> Path:
    """The agent job's result file: its result is that file (written atomically), not its log."""
    path = cfg.run_dir / "agents" / kind / "result.json"
    if not path.is_file():
        raise StageError(f"{job.name} exited 0 without writing {path}")
    return path


def _saved_models(job: Job) -> list[str]:
    """The models the identifier job has announced written, in order (its structured events)."""
    names = [e.get("model") for e in job.events(IDENTIFIER, SAVED_EVENT)]
    bad = [n for n in names if not isinstance(n, str) or not n]
    if bad:
        raise EventError(f"{IDENTIFIER}: malformed result event: {SAVED_EVENT} names model {bad[0]!r}")
    return [str(n) for n in names]


def _follow_saved(job: Job, on_saved: Callable[[str], None], deadline: float, poll_s: float = 0.05) -> None:
    """Call ``on_saved`` for each model the identifier job reports written, until the job ends (or the
    ``deadline``, monotonic, passes: the caller's wait then names the timeout)."""
    seen = 0
    while time.monotonic() < deadline:
        ended = job.finished()  # its exit line comes after all of its lines
        names = _saved_models(job)
        for name in names[seen:]:
            on_saved(name)
        seen = len(names)
        if ended:
            return
        time.sleep(poll_s)


def _check_identified(job: Job) -> None:
    """A finished identifier job must have said so in its ``identified`` event (a log line does not count)."""
    if not job.events(IDENTIFIER, IDENTIFIED_EVENT):
        raise StageError(f"{job.name} exited 0 without its {IDENTIFIED_EVENT!r} result event")


def write_run_facts(cfg: BenchConfig, extra: dict[str, Any]) -> Path:
    """``run.json``: the configuration, the stage timings and anything else worth keeping."""
    path = cfg.run_dir / "run.json"
    from msd_bench.graph.run_files import read_run_facts  # the report's readers: loaded by then

    previous = read_run_facts(path) if path.is_file() else {}  # corrupt: one line, not overwritten
    doc = json.loads(json.dumps(asdict(cfg), default=str))
    doc["timings"] = {**previous.get("timings", {}), **cfg.timings}
    doc.update(extra)
    return write_text_atomic(path, json.dumps(doc, indent=1, default=str) + "\n", root=cfg.run_dir)


BENCH_ENTRIES = frozenset({"excitation", "models", "agents", refine_stage.DIR, "report", "run.json",
                           JOBS_DIR})
"""What bench.py writes at the top of its --out: nothing else may be there."""


def probe_out(run_dir: Path) -> Path:
    """Before any stage: ``--out`` is created and writable, and holds nothing bench.py did not write.

    A run directory is re-entered on purpose (``--stages report --out <run>``,
    a later stage on earlier bags), so its own entries are accepted; a foreign
    file or a symlink among them means the directory is someone else's.
    """
    writable_dir(run_dir, "--out")
    for entry in sorted(os.listdir(run_dir)):
        if entry not in BENCH_ENTRIES and not entry.startswith(TEMP_PREFIX):
            raise OutputError(f"--out {run_dir} holds {entry!r}, which bench.py does not write; choose a new "
                              f"or empty directory, or a run directory of bench.py")
        if (run_dir / entry).is_symlink():
            raise OutputError(f"--out {run_dir}: {entry} is a symlink; refusing to write through it")
    return run_dir


def stage_names(stages: Sequence[str]) -> tuple[str, ...]:
    """Stages in their fixed order."""
    return tuple(s for s in STAGES if s in stages)


def timed(cfg: BenchConfig, name: str, fn: Callable[[], Any]) -> Any:
    """Run a stage and remember its wall time (and tell the live view, if any, when it starts and ends)."""
    t0 = time.perf_counter()
    live.stage(name, "running")
    state = "failed"
    try:
        result = fn()
        state = "done"
        return result
    finally:
        cfg.timings[name] = round(time.perf_counter() - t0, 2)
        live.stage(name, state, cfg.timings[name])
