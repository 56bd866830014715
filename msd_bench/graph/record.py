"""The recording stage of the main job: one verified rosbag2 bag per experiment.

Given a *running* plant-like process, each experiment is recorded through real
node processes, as on the rig: a recorder of ``joint_states`` (each row holds
x_k, v_k and the force actually applied, so it is the whole identification
record) and an excitation process start together; the excitation waits for
the plant and for the recorder's latched ``recorder/ready`` announcement (all
its readers matched, plus a grace for the publishers' side), resets the plant
to rest, settles, plays the seeded signal in lock-step and exits 0. The
recorder stops by itself after ``max_messages`` = samples (a timeout falls
back to a clean SIGINT). ``joint_states`` keeps a whole experiment in its
reliable history (``RECORD_DEPTH``), so a recorder slower than the lock-step
loop drains it late instead of losing samples.
Each node gets its experiment as one job file (:func:`msd_bench.app.job.job_document`, written
under the run's ``jobs/``: :class:`~msd_bench.graph.jobs.JobFiles`): the run's quantities (the
plant's ``dt``) and the stage's placement (:func:`excitation_placement`, :func:`recorder_placement`),
never ``-p`` strings with defaults of their own.
Every bag is then read back with :func:`read_experiment` and must hold exactly
the samples played, bit for bit after saturation. A bag that lacks samples
(the plant had not matched the new recorder yet: discovery is asymmetric and
takes 1-3 s) is recorded once more; a second shortfall, a wrong force or a
plant that missed its reset fails loudly, naming the experiment.

A plant with a sensor model (``truth=True``) publishes measured positions on
``joint_states`` and its noise-free rows on ``truth/joint_states``; both are
recorded (the truth for scoring only), and the start-at-rest check reads the
truth, since a measured x_0 is noise.

Real-time mode (``lockstep=False``) records the free-running plant from the
recorder's start to its stop, and the face's command topic beside
``joint_states`` (as a rosbag2 user records a rig), so the check is another:
no gap in the stamps, and the played samples located from the recorded
commands (the last N are the signal) and matching the signal over the cut
(:mod:`msd_bench.io.bags.played`).
"""

from __future__ import annotations

import json
import re
import shutil
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from msd_bench.app import plan
from msd_bench.app.config import RunConfig
from msd_bench.app.job import job_document
from msd_bench.app.serve_protocol import EventError
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.identification import excitation as exc
from msd_bench.core.rigs.hold import HoldLoop, beyond_loop
from msd_bench.graph.jobs import Job, JobFiles, JobServer, last_line
from msd_bench.graph.launch import LaunchError, ProcessSet
from msd_bench.io.bags.bag_interface import read_interface_experiment
from msd_bench.io.bags.bag_timing import READ
from msd_bench.io.bags.played import confirm_by_effort, locate_from_bag
from msd_bench.io.bags.reader import bag_info, read_topic
from msd_msgs_py.contract import (
    JOINT_STATES,
    LOCKSTEP_COMMAND_DEPTH,
    PLANT_NAMESPACE,
    TRUTH_JOINT_STATES,
    TopicSpec,
)
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface

if TYPE_CHECKING:
    from msd_bench.core.rigs.scales import Scales

SignalConfig = exc.PrbsConfig | exc.MultilevelConfig | exc.StepsConfig
Progress = Callable[[int, int, str], None]
_KINDS: dict[str, type] = {
    "prbs": exc.PrbsConfig, "multilevel": exc.MultilevelConfig, "steps": exc.StepsConfig,
}
RECORD_WINDOW = LOCKSTEP_COMMAND_DEPTH // 2
"""Lock-step commands in flight while recording (the excitation's ``window``): the plant, the
excitation and the recorder then work at once instead of taking turns (benchmarks/bench_record.py
times it against one exchange per command). Half the plant's command history, for margin: 128, where
32 recorded the paper's plan 15 % slower on this machine (measured A/B, same run)."""
REALTIME_TAIL_S = 0.3
"""Seconds a real-time recorder keeps recording after the excitation's last command: the row that
holds it comes up to a sample (plus the node's publish jitter) later, and the played samples are
located up to it (:mod:`msd_bench.io.bags.played`); a recorder stopped at once had 2 rows to spare."""
LOCKSTEP_COMMAND_BUDGET_S = 0.01
"""Wall seconds a lock-step experiment may take per command before the excitation is given up on
(a budget of the launcher, not the sample time: lock-step runs as fast as the middleware allows)."""
REST_TIMEOUT = 30.0
"""Seconds of zero force a node without reset gets to come to rest before an experiment plays anyway."""
_TOPICS = (JOINT_STATES,)
"""Recorded for identification: each joint_states row holds x_k, v_k and the force applied."""
_TRUTH_TOPICS = (JOINT_STATES, TRUTH_JOINT_STATES)
"""Recorded from a plant with a sensor: the measured rows and, for scoring only, the true ones."""


def recorded_topics(truth: bool, iface: PlantInterface = MSD_INTERFACE,
                    lockstep: bool = True) -> tuple[TopicSpec, ...]:
    """The topics a bag holds: ``joint_states`` (+ ``truth/joint_states`` from a plant with a sensor),
    and the face's command topic beside them in real time or when the effort is measured.

    Why the commands: a measured effort's applied force is rebuilt from them, and in real time they
    are what locates the played samples in a recording that starts before them
    (:mod:`msd_bench.io.bags.played`). A lock-step bag is exactly the played samples, so it goes without.
    """
    topics = _TRUTH_TOPICS if truth else _TOPICS
    if not (lockstep and iface.effort_is_commanded):
        topics = (*topics, iface.command)
    return topics


class RecordError(MsdBenchError):
    """An experiment could not be recorded, or its bag does not hold what was played."""


class SampleLossError(RecordError):
    """A bag lacks messages the plant published (worth one more try)."""


@dataclass(frozen=True)
class ExperimentSpec:
    """One excitation experiment: what to play and what to store with it."""

    name: str
    """Bag directory name under the run, e.g. ``bias_m10``, ``broad``, ``val_bias_p5``."""
    signal: str
    """Signal kind: ``prbs``, ``multilevel`` or ``steps``."""
    config: SignalConfig
    """Core config of that kind (its type must match ``signal``)."""
    seed: int = 0
    """Seed of the signal generator (ignored by ``steps``)."""
    params: Mapping[str, Any] = field(default_factory=dict)
    """Extra parameters stored in the bag (role train/validation, bias, plan seed ...)."""

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", self.name):
            raise ConfigError(f"experiment name {self.name!r} must be a plain directory name")
        if not isinstance(self.config, _KINDS.get(self.signal, ())):
            raise ConfigError(f"experiment {self.name}: signal {self.signal!r} does not match "
                              f"its config {type(self.config).__name__}")

    def force(self) -> np.ndarray:
        """The commands the excitation node plays: exactly the core generator's output."""
        if isinstance(self.config, exc.PrbsConfig):
            return exc.prbs(self.config, self.seed)
        if isinstance(self.config, exc.MultilevelConfig):
            return exc.multilevel(self.config, self.seed)
        return exc.steps(self.config)

    def bag_params(self) -> dict[str, Any]:
        """Everything needed to regenerate the signal, plus ``params``; stored in the bag."""
        return {"experiment": self.name, "signal": self.signal, "seed": self.seed,
                self.signal: asdict(self.config), **self.params}

    def job_params(self) -> dict[str, Any]:
        """The excitation job's fields that make it play :meth:`force`: the signal's under
        ``<signal>.``, named as the node's parameters are (JSON keeps every float exactly)."""
        section = {f"{self.signal}.{key}": list(value) if isinstance(value, tuple) else value
                   for key, value in asdict(self.config).items()}
        return {"signal": self.signal, "seed": self.seed, **section}


def paper_plan(id_seed: int, n_samples: int, val_samples: int,
               scales: Scales | None = None) -> list[ExperimentSpec]:
    """The application's experiment plan (:func:`msd_bench.app.plan.paper_plan`) as recordable specs
    (the lengths are the run's ``samples`` and ``val_samples``: no default of their own here; the
    forces and dwells on a rig of ``scales``)."""
    return [ExperimentSpec(e.name, e.kind, e.signal, e.seed,
                           {"role": e.role, "bias": e.bias, "id_seed": id_seed})
            for e in plan.paper_plan(id_seed, n_samples, val_samples, scales=scales)]


@dataclass(frozen=True)
class RecordTiming:
    """Wall time of one experiment, split so start-up cost can be told from sample cost."""

    name: str
    """Experiment name."""
    samples: int
    """Commands played."""
    startup_s: float
    """Recorder start until the excitation's first command could go (processes + discovery + settle)."""
    total_s: float
    """Recorder start until the bag was verified."""


TIMINGS: list[RecordTiming] = []
"""Timings of the experiments recorded by this process, newest last (for benchmarks)."""


def record_experiments(
    specs: Sequence[ExperimentSpec],
    out_dir: str | Path,
    procs: ProcessSet,
    namespace: str = PLANT_NAMESPACE,
    lockstep: bool = True,
    progress: Progress | None = None,
    *,
    jobs: JobFiles,
    run: RunConfig | None = None,
    truth: bool = False,
    rest: bool = False,
    iface: PlantInterface = MSD_INTERFACE,
    servers: RecordServers | None = None,
    window: int = RECORD_WINDOW,
) -> list[Path]:
    """Record every spec into ``out_dir/<name>`` from the running plant under ``namespace``.

    ``jobs``: where each node's job file is written (``jobs/recorder-<name>.json``,
    ``jobs/excitation-<name>.json``); ``run``: the run whose plant is recorded (its ``dt`` and
    ``F``; default the run configuration's defaults).
    ``servers``: the recorder and excitation processes, if the caller launched them early (their
    start-up then overlaps the plant's); they are closed at the end either way.
    ``truth``: the plant measures through a sensor and publishes ``truth/joint_states`` (recorded too).
    ``rest``: the node has no ``reset`` (a rig, real time): each experiment starts by zero force
    until the position is still, from wherever the mass rests.
    ``iface``: the node's face (docs/ros2-control.md); with a measured effort its command topic is
    recorded too, so identification can rebuild the applied force.
    ``window``: lock-step commands in flight (1 = one exchange per command; real time ignores it).
    """
    if lockstep and iface.reset is None:
        raise ConfigError(f"the {iface.kind} interface has no reset: record in real time")
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise ConfigError(f"experiment names must be unique, got {names}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    where = Placement(namespace, lockstep, truth, rest, iface, window, jobs, run or RunConfig())
    servers = (servers or RecordServers.launch(procs)).ready()
    bags = []
    try:
        for i, spec in enumerate(specs):
            def once(spec: ExperimentSpec = spec) -> Path:
                return record_one(spec, out / spec.name, servers, where)
            try:
                bag = once()
            except SampleLossError as err:
                print(f"warning: {err}; recording it again", file=sys.stderr, flush=True)
                shutil.rmtree(out / spec.name)
                bag = once()
            bags.append(bag)
            if progress is not None:
                progress(i + 1, len(specs), spec.name)
    finally:
        servers.close()
    return bags


@dataclass(frozen=True)
class RecordServers:
    """One served recorder and one served excitation process for every experiment of a stage.

    Why served (:mod:`msd_bench.nodes.serve`): as two fresh processes per
    experiment, start-up and discovery took longer than the samples did.
    """

    recorder: JobServer
    excitation: JobServer

    @classmethod
    def launch(cls, procs: ProcessSet) -> RecordServers:
        """Start both without waiting (their start-up overlaps whatever comes next)."""
        return cls(JobServer(procs, "recorder.py", "recorder"),
                   JobServer(procs, "excitation.py", "excitation"))

    def ready(self) -> RecordServers:
        """Wait until both take jobs."""
        self.recorder.ready()
        self.excitation.ready()
        return self

    def close(self) -> None:
        """No more experiments: both processes end."""
        for server in (self.excitation, self.recorder):
            server.close()


@dataclass(frozen=True)
class Placement:
    """Where and how the stage's experiments are recorded: what only the graph knows, beside the run."""

    namespace: str
    """The plant-like node's namespace."""
    lockstep: bool
    """Lock-step (one step per command, bags exactly the played samples) or real time."""
    truth: bool
    """The plant measures through a sensor: ``truth/joint_states`` is recorded too."""
    rest: bool
    """The node has no reset: zero force until still before each experiment."""
    iface: PlantInterface
    """The node's face (handed to both nodes as ``-p`` beside the job, as to every node)."""
    window: int
    """Lock-step commands in flight."""
    jobs: JobFiles
    """Where the job files go."""
    run: RunConfig
    """The run: the plant's ``dt`` and ``F`` come from it, through :func:`job_document`."""

    @property
    def force_limit(self) -> float:
        """The plant's F: the played commands saturate to it."""
        return self.run.plant.F

    @property
    def dt(self) -> float:
        """The plant's sample time."""
        return self.run.plant.dt

    @property
    def hold(self) -> HoldLoop | None:
        """The rig's stated hold loop, which its drive adds to every command (None: a bare plant)."""
        return self.run.hold


def record_one(spec: ExperimentSpec, bag: Path, servers: RecordServers, where: Placement) -> Path:
    """Record one experiment through a recorder and an excitation node; verify the bag."""
    if bag.exists():
        raise RecordError(f"experiment {spec.name}: bag {bag} already exists; refusing to overwrite")
    u = spec.force()
    t0 = time.monotonic()
    lockstep, iface = where.lockstep, where.iface
    # Both start at once; the excitation waits until the recorder's reader is in the graph,
    # then settles before playing.
    topics = recorded_topics(where.truth, iface, lockstep)
    max_messages = u.size * len(topics) if lockstep else 0
    rec_job = job_document("recorder", where.run, recorder_placement(spec, bag, where, max_messages, topics))
    rec = servers.recorder.submit([*where.jobs.args(f"recorder-{spec.name}", rec_job), *iface.ros_args()],
                                  name=f"recorder[{spec.name}]")
    ex_job = job_document("excitation", where.run, excitation_placement(spec, bag, where))
    ex = servers.excitation.submit(
        [*where.jobs.args(f"excitation-{spec.name}", ex_job), *iface.ros_args(),
         "-r", f"__ns:={where.namespace}"],
        name=f"excitation[{spec.name}]")
    try:
        _wait_playing(spec, ex, rec, 40.0 + (REST_TIMEOUT if where.rest else 0.0))
        startup = time.monotonic() - t0
        budget = 30.0 + u.size * (LOCKSTEP_COMMAND_BUDGET_S if lockstep else 1.5 * where.dt)
        status = _expect(spec, ex.wait, budget)
        if status != 0:
            raise RecordError(f"experiment {spec.name}: excitation exited {status}: "
                              f"{last_line(ex.lines) or 'no output'}")
        _finish_recorder(rec, lockstep)
    finally:
        for job in (ex, rec):
            job.stop()
    _verify(spec, bag, where.namespace, np.clip(u, -where.force_limit, where.force_limit),
            None if lockstep else where.dt, topics, iface, where.force_limit, where.dt, where.hold)
    TIMINGS.append(RecordTiming(spec.name, int(u.size), startup, time.monotonic() - t0))
    return bag


def recorder_placement(spec: ExperimentSpec, bag: Path, where: Placement, max_messages: int,
                       recorded: Sequence[TopicSpec] = _TOPICS) -> dict[str, Any]:
    """The recorder job's fields: the bag, its topics (joint_states, + truth: x, v and applied force
    per row), the experiment's parameters stored in it, and when it stops by itself."""
    return {"bag_path": str(bag), "namespace": where.namespace, "topics": [t.name for t in recorded],
            "params_json": json.dumps(spec.bag_params(), sort_keys=True), "max_messages": max_messages,
            "pooled": where.lockstep}  # lock-step: keep matched endpoints across jobs


def excitation_placement(spec: ExperimentSpec, bag: Path, where: Placement) -> dict[str, Any]:
    """The excitation job's fields: the signal, the pacing, how the plant is brought to rest, and the
    recorder it waits for (its ``dt`` is the run's, added by :func:`job_document`)."""
    start = {"rest_first": True, "rest_timeout": REST_TIMEOUT} if where.rest else {"reset_first": True}
    window = where.window if where.lockstep else 1  # lock-step needs reset: the face is msd's, the plant ours
    return {**spec.job_params(), "lockstep": where.lockstep, **start, "wait_recorder": str(bag),
            "settle": 0.3, "window": window, "pooled": where.lockstep}


def _wait_playing(spec: ExperimentSpec, ex: Job, rec: Job, timeout: float) -> None:
    """Wait for the excitation to start playing; fail at once if the recorder ended meanwhile."""
    deadline = time.monotonic() + timeout
    while True:
        # Playing is asked first, and again once the recorder has ended: on a loaded machine a short
        # lock-step experiment can play whole, and its recorder stop at its count, between two polls.
        if _playing(spec, ex):
            return
        if rec.finished():
            if _playing(spec, ex):
                return
            raise RecordError(f"experiment {spec.name}: {rec.name} ended ({rec.wait(5.0)}) "
                              f"before recording: {last_line(rec.lines) or 'no output'}")
        if ex.finished():
            raise RecordError(f"experiment {spec.name}: {ex.name} ended before playing: "
                              f"{last_line(ex.lines) or 'no output'}")
        if time.monotonic() >= deadline:
            raise RecordError(f"experiment {spec.name}: {ex.name} did not start playing within {timeout:g} s")
        time.sleep(0.02)


EXCITATION = "excitation"
"""The excitation node's name, which its events carry."""
PLAYING_EVENT = "playing"
"""The excitation's event as it plays its first command (``excitation_node.PLAYING_EVENT``)."""


def _playing(spec: ExperimentSpec, ex: Job) -> bool:
    """Whether the excitation job has announced it plays (its structured event, not a log line)."""
    try:
        return bool(ex.events(EXCITATION, PLAYING_EVENT))
    except EventError as err:
        raise RecordError(f"experiment {spec.name}: {err}") from None


def _expect(spec: ExperimentSpec, wait: Callable[..., Any], *args: Any) -> Any:
    """Call a launcher wait; its LaunchError becomes a RecordError naming the experiment."""
    try:
        return wait(*args)
    except LaunchError as err:
        raise RecordError(f"experiment {spec.name}: {err}") from None


def _finish_recorder(rec: Job, lockstep: bool) -> None:
    """Let a lock-step recorder reach ``max_messages`` by itself; else close it (as Ctrl-C would),
    in real time after :data:`REALTIME_TAIL_S`, so the rows that hold the last commands are in."""
    if lockstep:
        try:
            rec.wait(10.0)
            return
        except LaunchError:
            pass  # a message was lost: stop it cleanly, the check below names what is missing
    else:
        time.sleep(REALTIME_TAIL_S)
    rec.stop()



def _verify(spec: ExperimentSpec, bag: Path, namespace: str, u: np.ndarray, dt: float | None,
            topics: Sequence[TopicSpec], iface: PlantInterface, force_limit: float, sample_dt: float,
            hold: HoldLoop | None = None) -> None:
    """The bag holds exactly the played samples (lock-step: ``dt`` None), or a gap-free superset
    (``sample_dt``: the plant's sample time, which numbers the samples a shortfall names). Under a
    ``hold`` loop the effort the cut is confirmed against is the force beyond the loop's.

    With the truth recorded, every topic holds every sample and the plant must
    have started at rest by the *true* x_0 (the measured one is noisy).
    """
    try:
        info = bag_info(bag).topics
        counts = {t: info.get(t.resolve(namespace), ("", 0))[1] for t in topics}
        if not counts[JOINT_STATES]:
            raise SampleLossError(f"experiment {spec.name}: bag {bag} has no joint_states sample")
        # real time: the played samples located from the recorded commands, and checked against u
        cut = None if dt is None else locate_from_bag(bag, iface, namespace, u, force_limit)
        # our joint by name; a measured effort must be explained by the recorded commands (over the cut)
        experiment, _, _ = read_interface_experiment(bag, iface, namespace, force_limit=force_limit,
                                                     force_input="held", timing=replace(READ, dt=sample_dt),
                                                     played=None if cut is None else cut.rows)
        if hold is not None:  # the drive added the loop's force to the commands
            experiment = replace(experiment, u=beyond_loop(experiment.u, experiment.y, hold, sample_dt))
        if cut is not None and iface.effort_is_commanded:  # a measured effort was checked when rebuilt
            confirm_by_effort(bag, cut, experiment.u, sample_dt)
    except SampleLossError:
        raise
    except MsdBenchError as err:
        raise RecordError(f"experiment {spec.name}: {err}") from None
    if dt is None:
        got = {t.name: c for t, c in counts.items()}
        want = {t.name: u.size for t in topics}
        if got != want:
            _, msgs = read_topic(bag, JOINT_STATES.resolve(namespace))
            k = sorted(round((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec) / (sample_dt * 1e9))
                       for m in msgs)
            raise SampleLossError(f"experiment {spec.name}: expected {want} messages, got {got} "
                                  f"(samples {k[0]}..{k[-1]} present)")
        x0 = experiment.y[0] if experiment.truth is None else experiment.truth[0]
        if TRUTH_JOINT_STATES in topics and experiment.truth is None:
            raise RecordError(f"experiment {spec.name}: bag {bag} lacks the truth of the plant's sensor")
        if x0 != 0.0 or not np.array_equal(experiment.u, u):
            raise RecordError(f"experiment {spec.name}: recorded force differs from the signal "
                              f"(or the plant did not start at rest)")
        return
    _, msgs = read_topic(bag, JOINT_STATES.resolve(namespace))
    stamps = np.sort([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs])
    if len(experiment) < u.size or np.max(np.diff(stamps)) > 1.5e9 * dt:
        raise RecordError(f"experiment {spec.name}: real-time recording has gaps or too few samples")
    if cut is None:
        raise RecordError(f"experiment {spec.name}: bag {bag} holds no more samples than were played, "
                          f"or not its commands: the played samples cannot be located")
