"""bench.py behind the safety supervisor: wiring, options, and what it reported (docs/supervisor.md).

The supervisor node (``launch_scripts/supervisor.py``) runs under ``<NS>/supervisor`` and relays
the node's state to that namespace and the filtered commands back to ``NS``. The agent jobs (and,
with ``--supervise-recording``, the excitation jobs) keep ``plant_ns = NS`` — their bags are named
as the node's — and reach it only through remapped topics: every topic of the face, plus
``reference``, from ``NS/...`` to ``NS/supervisor/...``. Why remaps and not a second
``plant_ns``: one rule per topic of the face object, no branch on the face, and every node that
talks to a plant needs nothing new; the state goes through the supervisor too, so it has seen
each position before the controller answers it.

A rig has no ``reset``, so the node counts a *run* from each ``reference`` the agent announces
to ``validation_steps`` commands later, and prints one ``run`` event per run. The agents stage
runs its kinds one after another and each kind its runs in a fixed order (every member
nominally, then every scenario for every member), so the runs are handed back to the kinds by
their counts (:func:`runs_by_kind`) into ``agents/<kind>/supervisor.json``; the whole stage's
record is ``agents/supervisor.json``, which the report reads.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Protocol

from msd_bench.app.config import RunConfig
from msd_bench.app.serve_protocol import parse_event
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.description import RigDescription
from msd_bench.core.rigs.scales import Scales
from msd_bench.core.safety.supervisor import Limits, SupervisorOptions
from msd_bench.graph.jobs import Job, JobServer
from msd_bench.graph.launch import NodeProcess, ProcessSet, stop
from msd_bench.graph.record import RecordServers
from msd_bench.graph.run_files import read_result
from msd_bench.io.storage.supervisor_file import options_json, read_options, read_record, write_record
from msd_msgs_py.contract import REFERENCE, TopicSpec
from msd_msgs_py.interface import PlantInterface


class BenchConfig(Protocol):
    """What this module reads of ``graph/bench.py: BenchConfig`` (a Protocol, so this module need not
    import bench.py, which imports it: the layer test forbids the circle)."""

    @property
    def run(self) -> RunConfig: ...
    @property
    def run_dir(self) -> Path: ...
    @property
    def supervision(self) -> Supervision: ...
    @property
    def interface(self) -> PlantInterface: ...
    @property
    def plant_ns(self) -> str | None: ...
    @property
    def realtime(self) -> bool: ...
    @property
    def namespace(self) -> str: ...
    @property
    def rig_file(self) -> Path | None: ...

SCRIPT = "supervisor.py"
NODE = "supervisor"
"""The supervisor node's name: its events carry it (``supervisor_node.NODE_NAME``)."""
RUN_EVENT = "run"
DONE_EVENT = "supervisor_done"
SUFFIX = "supervisor"
"""The supervisor's namespace under the node's: ``/rig`` → ``/rig/supervisor``."""
RECORDING_ENVELOPE = 0.96
"""Default envelope with ``--supervise-recording``, a share of the half stroke (2.4 m of 2.5): the
±10 N bias records hold the mass near ±1.98 m and their PRBS swings it to 2.08 m, which the
validation default (0.9: 2.25 m, with the braking bound's margins) would override dozens of times
per record; at 2.4 m none of the held part is overridden on the default plant
(tests/graph/test_supervise.py). Their settle — a 10 N step from rest — overshoots into the stop
unsupervised, so there the supervisor brakes whatever the envelope."""
RECORD = "supervisor.json"
"""Under ``agents/``: the stage's record; under ``agents/<kind>/``: that kind's runs."""


@dataclass(frozen=True)
class Supervision:
    """Where the run puts the supervisor, and with which options (bench.py's ``--supervisor*``)."""

    validation: bool = False
    """The agents stage (validation, and a learner training on the node) goes through it; the default
    with ``--plant-ns``, off with ``--no-supervisor``."""
    recording: bool = False
    """The recording stage goes through it too (``--supervise-recording``; real time only)."""
    params: Path | None = None
    """``--supervisor-params FILE``: a JSON object of SupervisorOptions fields."""
    options: tuple[tuple[str, float], ...] = ()
    """``--supervisor-option KEY=VALUE`` items, over the file's."""
    asked: bool = False
    """The user chose (``--supervisor`` or ``--no-supervisor``) rather than took the default."""
    rig: RigDescription | None = None
    """``--rig FILE``: its stated delay and lag set the default latency
    (:meth:`RigDescription.latency`); a ``--supervisor-params`` file or option still wins."""

    @property
    def on(self) -> bool:
        """Whether any stage runs behind the supervisor."""
        return self.validation or self.recording

    def resolved(self, plant: PlantParams) -> SupervisorOptions:
        """The options: the file's (or the defaults), then the ``--supervisor-option`` items; with
        recording supervised and no envelope given, the recording's wider one (:data:`RECORDING_ENVELOPE`)."""
        scales = Scales.of(plant.L, plant.F, plant.dt)
        base = read_options(self.params) if self.params is not None else self.defaults(scales)
        merged = {f.name: getattr(base, f.name) for f in fields(base)} | dict(self.options)
        if self.recording and merged["envelope"] is None:
            merged["envelope"] = RECORDING_ENVELOPE * plant.x_max
        return SupervisorOptions.from_mapping(merged, what="--supervisor-option")

    def defaults(self, scales: Scales) -> SupervisorOptions:
        """The default options in the rig's scales, the latency the description's drive gives."""
        options = SupervisorOptions().scaled(scales)
        if self.rig is None:
            return options
        return replace(options, latency=self.rig.latency(options.latency))

    def limits(self, plant: PlantParams) -> Limits:
        """The limits in force on ``plant`` (a bad file or option: one ConfigError line)."""
        return self.resolved(plant).limits(plant)


def parse_option(text: str) -> tuple[str, float]:
    """One ``--supervisor-option KEY=VALUE`` (the value a finite number); ConfigError otherwise."""
    key, sep, value = text.partition("=")
    known = [f.name for f in fields(SupervisorOptions)]
    if not sep or key.strip() not in known:
        raise ConfigError(f"--supervisor-option {text!r}: expected KEY=VALUE with KEY one of "
                          f"{', '.join(known)}")
    try:
        number = float(value)
    except ValueError:
        raise ConfigError(f"--supervisor-option {text!r}: {value!r} is not a number") from None
    if not math.isfinite(number):
        raise ConfigError(f"--supervisor-option {text!r}: {value!r} is not a finite number")
    return key.strip(), number


def check(cfg: BenchConfig) -> None:
    """The run's supervision makes sense: options readable and inside the stroke, recording in real time."""
    sup = cfg.supervision
    if sup.recording and not cfg.realtime:
        raise ConfigError("--supervise-recording needs real time (--plant-ns or --realtime): a lock-step "
                          "excitation keeps commands in flight, ahead of the positions the filter judges on")
    if sup.on or sup.params is not None or sup.options:
        options = sup.resolved(cfg.run.plant)  # a bad file names itself
        try:
            options.limits(cfg.run.plant)
        except ConfigError as exc:
            given = [f"--supervisor-params {sup.params}"] if sup.params is not None else []
            given += ["--supervisor-option"] if sup.options else []
            raise ConfigError(f"{' and '.join(given) or 'supervisor defaults'}: {exc}") from None


def namespace(plant_ns: str) -> str:
    """The supervisor's namespace for the node under ``plant_ns``."""
    return f"{plant_ns.rstrip('/')}/{SUFFIX}"


def relayed(iface: PlantInterface) -> list[TopicSpec]:
    """Every topic a controller uses on this face, plus ``reference``: what the supervisor relays."""
    topics = [iface.command, iface.state, iface.position, iface.reset, REFERENCE]
    return [t for t in topics if t is not None]


def remap_args(iface: PlantInterface, plant_ns: str) -> list[str]:
    """ROS arguments that put a node talking to ``plant_ns`` behind the supervisor (module docstring)."""
    sup = namespace(plant_ns)
    args: list[str] = []
    for topic in relayed(iface):
        args += ["-r", f"{topic.resolve(plant_ns)}:={topic.resolve(sup)}"]
    return args


def agent_remaps(cfg: BenchConfig) -> list[str]:
    """The agent jobs' remaps: through the supervisor when validation is supervised, else none."""
    return remap_args(cfg.interface, cfg.namespace) if cfg.supervision.validation else []


class RemappedServer(JobServer):
    """A job server whose every job is put behind the supervisor (the excitation's, when asked)."""

    def __init__(self, procs: ProcessSet, script: str, name: str, remaps: Sequence[str]) -> None:
        super().__init__(procs, script, name)
        self.remaps = list(remaps)

    def submit(self, ros_args: Sequence[str], name: str) -> Job:
        """Run one node with these ROS arguments and the supervisor's remaps."""
        return super().submit([*ros_args, *self.remaps], name)


def record_servers(procs: ProcessSet, cfg: BenchConfig) -> RecordServers:
    """The recording stage's served processes, the excitation's behind the supervisor if asked."""
    if not cfg.supervision.recording:
        return RecordServers.launch(procs)
    command = cfg.interface.command  # the bag keeps what the excitation sent, the effort what was applied
    return RecordServers(RemappedServer(procs, "recorder.py", "recorder",
                                        ["-r", f"{command.resolve(cfg.namespace)}:="
                                               f"{command.resolve(namespace(cfg.namespace))}"]),
                         RemappedServer(procs, "excitation.py", "excitation",
                                        remap_args(cfg.interface, cfg.namespace)))


def write_options(cfg: BenchConfig) -> Path:
    """The options in force, every derived limit spelled out, as ``jobs/supervisor.json`` (the node's
    ``options_file`` and the run's record of them)."""
    from msd_bench.graph.jobs import JOBS_DIR
    from msd_bench.io.storage.atomic import write_text_atomic

    text = options_json(cfg.supervision.resolved(cfg.run.plant), cfg.run.plant)
    return write_text_atomic(cfg.run_dir / JOBS_DIR / RECORD, text, root=cfg.run_dir)


def node_args(cfg: BenchConfig, options_file: Path) -> list[str]:
    """ROS arguments of the supervisor process for this run."""
    return ["-p", f"plant_ns:={cfg.namespace}", "-p", f"preset:={cfg.run.preset}",
            "-p", f"options_file:={options_file}", "-p", f"lockstep:={str(not cfg.realtime).lower()}",
            "-p", f"run_steps:={cfg.run.validation_steps}", "-p", f"reference:={float(cfg.run.target)!r}",
            "-r", f"__ns:={namespace(cfg.namespace)}", *cfg.interface.ros_args(),
            *([] if cfg.rig_file is None else ["--params-file", str(cfg.rig_file)])]


class SupervisorProcess:
    """The run's supervisor node process: start it, wait for it, stop it and read what it reported."""

    def __init__(self, procs: ProcessSet, cfg: BenchConfig) -> None:
        self.cfg = cfg
        self.proc: NodeProcess = procs.start(SCRIPT, node_args(cfg, write_options(cfg)), name=NODE)
        self._ready = False

    def ready(self, timeout: float = 60.0) -> SupervisorProcess:
        """Wait until it has printed its limits (it is built and spinning)."""
        if not self._ready:
            self.proc.wait_for_line(r"supervisor: envelope", timeout)
            self._ready = True
        return self

    def finish(self) -> dict[str, Any]:
        """Stop it (it prints its totals as it closes), write the stage's record and each kind's runs."""
        stop(self.proc)
        record = stage_record(self.proc.lines)
        record["limits"] = self.cfg.supervision.limits(self.cfg.run.plant).describe()
        record["stages"] = [s for s, on in (("recording", self.cfg.supervision.recording),
                                            ("validation", self.cfg.supervision.validation)) if on]
        if self.cfg.supervision.validation:
            record["by_kind"] = write_kind_records(self.cfg, record["runs"])
        write_record(self.cfg.run_dir / "agents" / RECORD, record, root=self.cfg.run_dir)
        return record


def stage_record(lines: Sequence[str]) -> dict[str, Any]:
    """The ``run`` events and the ``supervisor_done`` totals in the supervisor's output lines."""
    runs: list[dict[str, Any]] = []
    totals: dict[str, Any] | None = None
    for line in lines:
        event = parse_event(line, NODE)
        if event is None:
            continue
        payload = {k: v for k, v in event.items() if k not in ("node", "event")}
        if event["event"] == RUN_EVENT:
            runs.append(payload)
        elif event["event"] == DONE_EVENT:
            totals = payload
    return {"runs": runs, "totals": totals}


def expected_runs(cfg: BenchConfig, kind: str) -> list[dict[str, Any]]:
    """The validation runs kind's agent ran, in its order: each seed nominally, then each scenario
    for each seed (read from its ``result.json``); [] when it wrote none."""
    path = cfg.run_dir / "agents" / kind / "result.json"
    if not path.is_file():
        return []
    doc = read_result(path)
    seeds = [int(row["seed"]) for row in doc.per_seed]
    runs = [{"scenario": "nominal", "seed": s} for s in seeds]
    for sid in doc.on_node_scenarios:
        runs += [{"scenario": sid, "seed": s} for s in seeds]
    return runs


def run_order(cfg: BenchConfig) -> list[str]:
    """The run's kinds in the order their agents ran: the served agent process runs its jobs one after
    another, each writing its ``result.json`` as it ends, so those files' times order them (Dyna-Q,
    submitted before identification, ran first; a pipelined lock-step run submits as models appear)."""
    def ended(kind: str) -> int:
        path = cfg.run_dir / "agents" / kind / "result.json"
        return path.stat().st_mtime_ns if path.is_file() else 0
    return sorted(cfg.run.agents, key=ended)


def runs_by_kind(cfg: BenchConfig, runs: Sequence[dict[str, Any]]) -> dict[str, list[dict[str, Any]]] | None:
    """The supervisor's runs handed to the kinds in the order they ran; None if the counts disagree
    (a run the node did not see, or one too many: then nothing is attributed rather than guessed)."""
    wanted = {kind: expected_runs(cfg, kind) for kind in run_order(cfg)}
    if sum(len(w) for w in wanted.values()) != len(runs):
        return None
    out: dict[str, list[dict[str, Any]]] = {}
    i = 0
    for kind, slots in wanted.items():
        out[kind] = [{**slot, **runs[i + j]} for j, slot in enumerate(slots)]
        i += len(slots)
    return out


def write_kind_records(cfg: BenchConfig, runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """``agents/<kind>/supervisor.json`` per kind (its runs, overrides and aborts); the summary."""
    by_kind = runs_by_kind(cfg, runs)
    if by_kind is None:
        expected = sum(len(expected_runs(cfg, k)) for k in cfg.run.agents)
        return {"attributed": False, "note": f"the supervisor reported {len(runs)} runs where the agents "
                                             f"ran {expected}: not attributed to kinds"}
    summary: dict[str, Any] = {"attributed": True, "kinds": {}}
    for kind, kind_runs in by_kind.items():
        if not kind_runs:
            continue
        doc = kind_summary(kind_runs)
        write_record(cfg.run_dir / "agents" / kind / RECORD, {**doc, "runs": kind_runs}, root=cfg.run_dir)
        summary["kinds"][kind] = doc
    return summary


def kind_summary(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One kind's runs in brief: how many, commands overridden, and every aborted run with its reason."""
    steps = sum(int(r.get("steps", 0)) for r in runs)
    overridden = sum(int(r.get("overridden", 0)) for r in runs)
    aborted = [{"scenario": r["scenario"], "seed": r["seed"], "reason": r["aborted"]}
               for r in runs if r.get("aborted")]
    return {"runs": len(runs), "steps": steps, "overridden": overridden,
            "runs_with_override": sum(int(r.get("overridden", 0)) > 0 for r in runs), "aborted": aborted}


def report_facts(cfg: BenchConfig) -> dict[str, Any]:
    """What the report says about the supervisor: on or off and why, and what it reported."""
    path = cfg.run_dir / "agents" / RECORD
    sup = cfg.supervision
    if not sup.on:
        why = ("--no-supervisor" if cfg.plant_ns is not None else
               "the emulator's own plant; ask with --supervisor")
        return {"on": False, "line": f"Supervisor: off ({why})."}
    if not path.is_file():
        return {"on": True, "line": "Supervisor: on, but no record of it in this run directory "
                                    "(the stage behind it did not run)."}
    return {"on": True, **report_line(read_record(path))}


def report_line(record: dict[str, Any]) -> dict[str, Any]:
    """The report's line from the stage's record, and the counts it quotes."""
    runs = record.get("runs", [])
    totals = record.get("totals") or {}
    inside: dict[str, int] = {}
    for r in runs:
        for reason, n in r.get("overrides", {}).items():
            inside[reason] = inside.get(reason, 0) + int(n)
    aborted = [r for r in runs if r.get("aborted")]
    by_kind = record.get("by_kind", {})
    named = [f"{kind} {a['scenario']} seed {a['seed']} ({a['reason']})"
             for kind, doc in by_kind.get("kinds", {}).items() for a in doc.get("aborted", [])]
    overrides = ", ".join(f"{k} {n}" for k, n in inside.items() if n) or "none"
    outside = ", ".join(f"{k} {n}" for k, n in (totals.get("outside_overrides") or {}).items() if n) or "none"
    stages = " and ".join(record.get("stages", [])) or "no stage"
    line = (f"Supervisor: on for {stages} ({record.get('limits', '')}); {len(runs)} validation runs, "
            f"overrides in them: {overrides}; aborted runs: {len(aborted)}"
            f"{' — ' + '; '.join(named) if named else ''}; outside runs (rests, recording, learning on the "
            f"node): {totals.get('outside_steps', 0)} commands, overrides: {outside}.")
    if not by_kind.get("attributed", True):
        line += f" {by_kind.get('note', '')}."
    return {"line": line, "runs": len(runs), "overrides": inside, "aborted": len(aborted),
            "aborted_runs": named, "outside_overrides": totals.get("outside_overrides", {}),
            "estop_latches": totals.get("estop_latches", 0)}


def announce(cfg: BenchConfig) -> str:
    """The start-up line: where the supervisor is, or why it is not, and the limits it holds."""
    sup = cfg.supervision
    if not sup.on:
        line = str(report_facts(cfg)["line"])
        return line[:-1] + ("; recording unsupervised" if cfg.plant_ns else "")
    stages = " and ".join(s for s, on in (("recording", sup.recording), ("validation", sup.validation)) if on)
    source = f" from {sup.params}" if sup.params is not None else " (defaults from the stroke and F)"
    extra = "" if sup.recording else "; recording unsupervised (--supervise-recording to change)"
    return (f"{stages} behind {namespace(cfg.namespace)}{extra}; "
            f"{sup.limits(cfg.run.plant).describe()}{source if not sup.options else source + ' and options'}")
