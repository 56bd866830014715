"""bench.py's command line and its run: options → :class:`BenchConfig` → stages → Table 1.

``launch_scripts/bench.py`` only calls :func:`main`; everything it does lives
here, beside the stages, so the run can be driven from tests and benchmarks.
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib
import math
import os
import sys
import threading
from dataclasses import replace
from pathlib import Path
from typing import IO, Any

from msd_bench.app import plant_ns
from msd_bench.app.agents import BENCH_AGENTS
from msd_bench.app.config import RunConfig
from msd_bench.app.job import agent_params
from msd_bench.app.options import add_run_arguments, run_config_from_args
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.rigs.description import RigDescription
from msd_bench.designs import check_decisions
from msd_bench.designs.kinds import node_budget_note, on_node
from msd_bench.designs.protocol import settings_from
from msd_bench.graph import supervise
from msd_bench.graph.bench import (
    STAGES,
    BenchConfig,
    agent_starter,
    pipelined,
    probe_out,
    stage_agents,
    stage_identify,
    stage_names,
    stage_record,
    start_model_free,
    start_plant,
    timed,
    write_run_facts,
)
from msd_bench.graph.domains import claim_domain
from msd_bench.graph.jobs import Job, JobServer
from msd_bench.graph.launch import ProcessSet, caller_env, process_group, stop
from msd_bench.graph.live import LiveStageProgress as StageProgress
from msd_bench.graph.live import live_view
from msd_bench.graph.live import log as live_log
from msd_bench.graph.rig_option import add_rig_option, apply_rig, given_options
from msd_bench.io.bags.bag_records import roles_from_dir
from msd_bench.io.reports.live_server import DEFAULT_PORT
from msd_msgs_py.interface import add_cli_options, from_cli

REPO = Path(__file__).resolve().parents[2]
BENCH_DEFAULTS: dict[str, Any] = {"seeds": 3, "dyna_episodes": 5, "val_samples": 2_000,
                                  "agents": BENCH_AGENTS}
"""bench.py's defaults where they differ from ``msd-bench paper``'s (every step goes over DDS)."""


def _wants_plant_ns(argv: list[str]) -> bool:
    """Whether ``--plant-ns`` is given: its runs have other defaults (docs/plant-ns.md)."""
    pre = argparse.ArgumentParser(add_help=False)
    pre.add_argument("--plant-ns")
    known, _ = pre.parse_known_args(argv)
    return known.plant_ns is not None


def parse(argv: list[str]) -> argparse.Namespace:
    """Command-line options (under ``--plant-ns`` the defaults of :data:`plant_ns.DEFAULTS`)."""
    p = argparse.ArgumentParser(prog="bench.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p, **(plant_ns.DEFAULTS if _wants_plant_ns(argv) else BENCH_DEFAULTS))
    p.add_argument("--out", type=Path, help="run directory (default bags/<run-id>)")
    p.add_argument("--bags", type=Path, help="identify from these experiment bags instead of recording")
    p.add_argument("--stages", default=",".join(STAGES), help=f"subset of {','.join(STAGES)}")
    p.add_argument("--realtime", action="store_true", help="run the plant at true 100 Hz (slow)")
    p.add_argument("--via-ros", action="store_true",
                   help="train over surrogate nodes in lock-step instead of in-process (slow)")
    p.add_argument("--domain-id", type=int,
                   help="ROS_DOMAIN_ID of the run (default: a random one; with --plant-ns the caller's)")
    p.add_argument("--plant-ns", metavar="NS",
                   help="run against the node serving NS (e.g. /rig): no emulator, real time, no reset")
    p.add_argument("--node-scenarios", metavar="IDS",
                   help="with --plant-ns: set-point/disturbance scenarios validated on the node, separated "
                        f"by ';' (default {';'.join(plant_ns.DEFAULT_SCENARIOS)}; '' for none)")
    p.add_argument("--scenario-kinds", metavar="KINDS",
                   help="with --plant-ns: agent kinds validated under --node-scenarios "
                        f"(default those of {','.join(plant_ns.DEFAULT_SCENARIO_KINDS)} that run)")
    p.add_argument("--live", nargs="?", type=int, const=DEFAULT_PORT, metavar="PORT",
                   help=f"serve a live view (Foxglove WebSocket) on ws://127.0.0.1:PORT for the run "
                        f"(default port {DEFAULT_PORT}; 0 picks a free one; docs/live.md)")
    p.add_argument("--live-wait", type=float, default=0.0, metavar="SECONDS",
                   help="with --live: before the first stage, wait up to SECONDS for a viewer to "
                        "subscribe to the plant's rows (an emulated run can end in seconds)")
    p.add_argument("--refine", type=int, default=0, metavar="R",
                   help="with --plant-ns: after the agents, refine each kind whose model is fitted from the "
                        "broad record on the node: try, refit from the open-loop and closed-loop bags, "
                        "retrain, try again, up to R rounds; keep the best measured try, validate it afresh "
                        "(report/refine.md; docs/rigs.md §Refinement in real time)")
    p.add_argument("--refine-weight", type=int, default=1, metavar="W",
                   help="with --refine: how many times each closed-loop record counts in a refit")
    add_cli_options(p)
    add_rig_option(p)
    supervise_options(p)
    args = p.parse_args(argv)
    args.given = given_options(argv)
    return args


def supervise_options(p: argparse.ArgumentParser) -> None:
    """The ``--supervisor*`` options (docs/supervisor.md §bench.py)."""
    g = p.add_argument_group("safety supervisor (docs/supervisor.md)")
    on = g.add_mutually_exclusive_group()
    on.add_argument("--supervisor", action="store_true",
                    help="validate behind the supervisor (the default with --plant-ns)")
    on.add_argument("--no-supervisor", action="store_true",
                    help="validate without the supervisor (said in the report)")
    g.add_argument("--supervise-recording", action="store_true",
                   help="record behind the supervisor too (real time only; unsupervised by default; a "
                        "record it overrides much, like the paper's broad one, is refused by the cut)")
    g.add_argument("--supervisor-params", type=Path, metavar="FILE",
                   help="JSON object of supervisor options (default: derived from the stroke and F)")
    g.add_argument("--supervisor-option", action="append", default=[], metavar="KEY=VALUE",
                   help="one supervisor option, over the file's (repeatable), e.g. envelope=2.0")


def supervision(args: argparse.Namespace, rig: RigDescription | None = None) -> supervise.Supervision:
    """Where the supervisor goes: validation by default with --plant-ns, on the emulator if asked; with
    ``--rig``, its latency from the description's stated drive."""
    validation = args.supervisor or (args.plant_ns is not None and not args.no_supervisor)
    return supervise.Supervision(
        validation=validation, recording=args.supervise_recording,
        params=args.supervisor_params.absolute() if args.supervisor_params else None,
        options=tuple(supervise.parse_option(t) for t in args.supervisor_option),
        asked=args.supervisor or args.no_supervisor, rig=rig)


def _plant_ns_fields(args: argparse.Namespace, run: RunConfig) -> tuple[RunConfig, dict[str, Any]]:
    """The run without the kinds a foreign node cannot serve, and BenchConfig's --plant-ns fields."""
    kept, dropped = plant_ns.split_kinds(run.agents)
    defaults = plant_ns.default_scenarios(run.scales)
    text = ";".join(defaults) if args.node_scenarios is None else args.node_scenarios
    scenarios = tuple(s.strip() for s in text.split(";") if s.strip())
    if args.scenario_kinds is None:
        kinds = tuple(k for k in plant_ns.DEFAULT_SCENARIO_KINDS if k in kept)
    else:
        kinds = tuple(k.strip() for k in args.scenario_kinds.split(",") if k.strip())
    return replace(run, agents=kept), {"plant_ns": args.plant_ns, "node_scenarios": scenarios,
                                       "scenario_kinds": kinds, "left_out": dropped}


def live_wait(args: argparse.Namespace) -> float:
    """``--live-wait``'s seconds, refused in one line without ``--live`` or when not a finite number >= 0."""
    wait = float(args.live_wait)
    if not (math.isfinite(wait) and wait >= 0.0):
        raise ConfigError(f"--live-wait {args.live_wait}: give seconds, a finite number >= 0")
    if wait > 0.0 and args.live is None:
        raise ConfigError("--live-wait needs --live")
    return wait


def config(args: argparse.Namespace) -> BenchConfig:
    """The run's configuration from the options."""
    # relative paths mean the caller's directory (children run in the repository)
    run_dir = (args.out or REPO / "bags" / dt.datetime.now().strftime("%Y%m%d-%H%M%S")).absolute()
    stages = stage_names([s.strip() for s in args.stages.split(",")])
    rig = apply_rig(args, getattr(args, "given", frozenset()))
    run = run_config_from_args(args)
    if rig is not None:
        run = run.on_rig(rig)  # the rig's plant and scales; the budgets the same seconds
        for kind in run.agents:  # a design that cannot hold its command between decisions: one line now
            check_decisions(kind, run.decision_samples)
    extra: dict[str, Any] = {}
    if args.plant_ns is not None:
        run, extra = _plant_ns_fields(args, run)
    elif args.node_scenarios is not None or args.scenario_kinds is not None:
        raise ConfigError("--node-scenarios and --scenario-kinds need --plant-ns")
    return BenchConfig(
        run_dir=Path(run_dir), run=run, realtime=args.realtime or args.plant_ns is not None,
        via_ros=args.via_ros, bags=args.bags.absolute() if args.bags else None,
        stages=stages or tuple(args.stages.split(",")), interface=from_cli(args), live_port=args.live,
        live_wait_s=live_wait(args),
        supervision=supervision(args, rig), rig=rig_facts(rig, args), refine=args.refine,
        refine_weight=args.refine_weight, rig_file=None if rig is None else args.rig.absolute(), **extra)


def rig_facts(rig: RigDescription | None, args: argparse.Namespace) -> dict[str, object] | None:
    """What run.json and Table 1 state about ``--rig``: the file's facts, with the face the run used (an
    explicit ``--interface`` wins over the file's)."""
    return None if rig is None else {**rig.facts(), "interface": from_cli(args).kind}


REPORT_MODULE = "msd_bench.graph.bench_report"
"""The report stage's module: importing it (python-control, matplotlib, SciPy) takes about 2 s."""


def prewarm(module: str) -> None:
    """Import ``module`` on a background thread now, so a later import finds it done.

    Why: during the agents stage this process only waits for the agent jobs,
    whose lock-step exchange leaves part of a core free; the report's imports
    then cost the run nothing instead of 2 s after the last agent.
    """
    threading.Thread(target=importlib.import_module, args=(module,), name="prewarm", daemon=True).start()


def say(line: str) -> None:
    """Progress line on stderr."""
    print(f"[bench] {line}", file=sys.stderr, flush=True)
    live_log(line)


def write_plant_model(cfg: BenchConfig) -> None:
    """The emulator's own model, for the on-plant reference agent (not identified)."""
    from msd_bench.core.physics.model import plant_model
    from msd_bench.io.storage import artifacts

    path = cfg.run_dir / "models" / "plant.json"
    if not path.exists():
        prov = artifacts.Provenance(parameters={"preset": cfg.run.preset, "note": "the emulator itself"})
        artifacts.save_model(plant_model(cfg.run.plant), path, prov)


def run_graph_stages(cfg: BenchConfig) -> None:
    """record → identify → agents, each through node processes, the plant started once.

    With a sensor (``--record-noise``/``--record-quant``) the plant records
    through it, then is restarted ideal for the agents (validated on the true
    plant, as in ``msd-bench paper``).
    """
    recording = "record" in cfg.stages and cfg.bags is None
    sensor = recording and cfg.run.sensor is not None
    with process_group(env=caller_env() if cfg.plant_ns is not None else None) as procs:
        # served processes start first: their imports overlap the plant's start and identification
        servers = supervise.record_servers(procs, cfg) if recording else None
        guard = supervised_stages(cfg, procs, recording)
        agent_server = JobServer(procs, "agent.py", "agent") if "agents" in cfg.stages else None
        ident_server = JobServer(procs, "identifier.py", "identifier") if identifies(cfg) else None
        plant = None
        if ("record" in cfg.stages or "agents" in cfg.stages) and cfg.plant_ns is None:
            plant = timed(cfg, "plant_start", lambda: start_plant(procs, cfg, sensor))
        if recording:
            if guard is not None and cfg.supervision.recording:
                guard.ready()
            with StageProgress("record") as bar:
                timed(cfg, "record", lambda: stage_record(cfg, procs, lambda d, t, n: bar.update(n, d, t),
                                                          servers))
        if guard is not None and cfg.supervision.validation:
            guard.ready()  # before the first agent job: Dyna-Q starts on the node beside identification
        elif guard is not None:
            timed(cfg, "supervisor_record", guard.finish)
            guard = None
        early: dict[str, Job] = {}
        if "identify" in cfg.stages:
            if agent_server is not None and not sensor:  # with a sensor the agents get a restarted plant
                early = start_model_free(cfg, agent_server)
                if early:
                    say(f"{', '.join(early)}: learning on the plant while the surrogates are identified")
            if identifies(cfg):
                say("identifying surrogates (identifier node)")
                on_saved = (agent_starter(cfg, agent_server, early, say)
                            if agent_server is not None and pipelined(cfg, sensor) else None)
                fits = timed(cfg, "identify", lambda: stage_identify(cfg, procs, on_saved, ident_server))
                from msd_bench.io.storage.run_output import FAILED_KEY  # loaded once there are models

                for name, why in fits.pop(FAILED_KEY, {}).items():
                    say(f"  {name}: FAILED (its agents are reported failed): {why}")
                for name, f in fits.items():
                    truth = ("" if f.get("sim_fit_truth") is None
                             else f" ({f['sim_fit_truth']:.1f} % vs truth)")
                    say(f"  {name}: fit {f['sim_fit']:.1f} % simulation{truth}, "
                        f"{f['one_step_fit']:.2f} % one-step")
            if cfg.plant_ns is None:
                write_plant_model(cfg)
        if "agents" in cfg.stages:
            if "report" in cfg.stages:
                prewarm(REPORT_MODULE)
            if sensor and plant is not None:
                stop(plant)
                timed(cfg, "plant_restart", lambda: start_plant(procs, cfg, sensor=False))
            with StageProgress("agents") as bar:
                def agents_bar(done: int, total: int, name: str) -> None:
                    bar.update(name, done, total)

                timed(cfg, "agents", lambda: stage_agents(cfg, procs, say, agents_bar, agent_server, early))
        if guard is not None:
            say(supervise.report_line(timed(cfg, "supervisor_record", guard.finish))["line"])
        if cfg.refine and "agents" in cfg.stages:
            run_refine(cfg, procs)


def run_refine(cfg: BenchConfig, procs: ProcessSet) -> None:
    """The refinement stage (``--refine R``), after the agents and their supervisor's record."""
    from msd_bench.graph.bench import agent_placement, job_args, unmade_agents
    from msd_bench.graph.refine import stage_refine

    say(f"refining on {cfg.namespace}: up to {cfg.refine} round(s) per kind and seed")
    def args(name: str, doc: dict[str, Any]) -> list[str]:
        return [*job_args(cfg, name, doc), *supervise.agent_remaps(cfg)]

    unmade = list(unmade_agents(cfg))
    timed(cfg, "refine", lambda: stage_refine(cfg, procs, say, lambda kind: agent_placement(cfg, kind), args,
                                              unmade))


def identifies(cfg: BenchConfig) -> bool:
    """Whether this run fits surrogates: only kinds that train on the plant (``dyna-q``, ``plant``,
    on-plant deep RL) need none, and the identifier would refuse an empty list of model kinds."""
    return "identify" in cfg.stages and bool(cfg.run.surrogates_needed())


def supervised_stages(cfg: BenchConfig, procs: ProcessSet,
                      recording: bool) -> supervise.SupervisorProcess | None:
    """Start the supervisor now if a stage of this run goes through it (its start-up overlaps the rest)."""
    sup = cfg.supervision
    wanted = (sup.recording and recording) or (sup.validation and "agents" in cfg.stages)
    return supervise.SupervisorProcess(procs, cfg) if wanted else None


def expected_duration(cfg: BenchConfig) -> plant_ns.Duration:
    """The real-time part of a --plant-ns run, from its sample counts."""
    r = cfg.run
    return plant_ns.expected_seconds(
        samples=r.samples, val_samples=r.val_samples, agents=r.agents if "agents" in cfg.stages else (),
        seeds=len(cfg.seeds), validation_steps=r.validation_steps, dyna_episodes=r.dyna_episodes,
        steps=r.steps, scenarios=cfg.node_scenarios, scenario_kinds=cfg.scenario_kinds, dt=r.plant.dt,
        record="record" in cfg.stages and cfg.bags is None)


def dyna_budget(cfg: BenchConfig) -> str:
    """The budget of the kinds that train on the node (Dyna-Q, on-plant deep RL), stated in the report
    ('' without one): each kind's seeds x episodes x steps real interactions."""
    free = on_node(cfg.run.agents)
    if not free:
        return ""
    r = cfg.run
    real = len(cfg.seeds) * r.dyna_episodes * r.steps
    note = node_budget_note(free, settings_from(agent_params(r)))
    return (f"Trained on {cfg.plant_ns} in real time ({', '.join(free)}): {len(cfg.seeds)} seed(s) x "
            f"{r.dyna_episodes} episode(s) x {r.steps} steps = {real} real interactions per kind "
            f"({real * r.plant.dt / 60:.1f} min each; paper: 300 episodes){note}")


def plant_ns_facts(cfg: BenchConfig) -> dict[str, Any]:
    """What the report must say about a run on a foreign node."""
    return {"plant_ns": cfg.plant_ns, "interface": cfg.interface.as_dict(), "realtime": True, "reset": False,
            "left_out": plant_ns.left_out_note(cfg.left_out), "dyna_budget": dyna_budget(cfg),
            "node_scenarios": list(cfg.node_scenarios), "scenario_kinds": list(cfg.scenario_kinds),
            "expected_seconds": round(expected_duration(cfg).total, 1)}


def announce_plant_ns(cfg: BenchConfig) -> None:
    """Print what a --plant-ns run will do and how long its real-time part takes."""
    say(f"plant-like node {cfg.plant_ns}: no emulator started; real time, no reset "
        f"(zero force until still before each experiment and episode)")
    say(cfg.interface.describe(cfg.plant_ns or ""))
    for line in (plant_ns.left_out_note(cfg.left_out), dyna_budget(cfg), expected_duration(cfg).line()):
        if line:
            say(line)


def run(cfg: BenchConfig) -> int:
    """All requested stages; prints Table 1 and where the report is."""
    probe_out(cfg.run_dir)
    if cfg.bags is not None and "identify" in cfg.stages:
        # a killed or badly timed bag is one line now, not after the stage starts
        roles_from_dir(cfg.bags, cfg.namespace, cfg.run.plant.dt)
    say(f"run directory {cfg.run_dir}  (ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']})")
    if cfg.plant_ns is not None:
        announce_plant_ns(cfg)
    say(supervise.announce(cfg))
    if any(s in cfg.stages for s in ("record", "identify", "agents")):
        run_graph_stages(cfg)
    facts = {"preset": cfg.run.preset, "seeds": len(cfg.seeds), "window": cfg.run.window,
             "mode": "ros-graph", "lockstep": not cfg.realtime, "stage_seconds": cfg.timings,
             "agents": list(cfg.run.agents)}
    if cfg.plant_ns is not None:
        facts.update(plant_ns_facts(cfg))
    facts["supervisor"] = supervise.report_facts(cfg)
    refined = refine_facts(cfg)
    if refined is not None:
        facts["refine"] = refined
    if "report" in cfg.stages:
        from msd_bench.graph.bench_report import write_bench_report  # prewarmed during the agents stage

        paths = timed(cfg, "report", lambda: write_bench_report(cfg, facts))
        print(paths["table"]["md"].read_text())
        print(paths["robustness"]["md"].read_text())
        say(f"report: {paths['table']['md'].parent}")
    table = cfg.run_dir / "report" / "refine.md"
    if refined is not None and table.is_file():
        print(table.read_text())
    write_run_facts(cfg, {"ros_domain_id": int(os.environ["ROS_DOMAIN_ID"]),
                          **({"refine": refined} if refined is not None else {})})
    say("stage seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in cfg.timings.items()))
    return 0


def refine_facts(cfg: BenchConfig) -> dict[str, Any] | None:
    """The refinement stage's summary per kind and round (``refine/refine.json``), None without one."""
    from msd_bench.graph.refine import DIR, RESULT

    path = cfg.run_dir / DIR / RESULT
    if not path.is_file():
        return None
    from msd_bench.graph.run_files import read_json_object

    doc = read_json_object(path)
    return {"rounds": doc.get("rounds"), "refine_weight": doc.get("refine_weight"),
            "summary": doc.get("summary"),
            "chosen": {k: [r.get("chosen_round") for r in rows] for k, rows in doc.get("kinds", {}).items()}}


def use_domain(args: argparse.Namespace) -> IO[str] | None:
    """Set the run's ROS domain; returns the lock to hold (None: the caller's domain, not locked).

    The emulator's runs claim a free domain of their own on localhost. A
    --plant-ns run must see the node the caller sees: it keeps the caller's
    ``ROS_DOMAIN_ID`` and discovery range, unless ``--domain-id`` is given.
    """
    if args.plant_ns is not None and args.domain_id is None:
        os.environ.setdefault("ROS_DOMAIN_ID", "0")
        return None
    if args.plant_ns is None:
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    domain, lock = claim_domain(args.domain_id)
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    return lock


def main(argv: list[str] | None = None) -> int:
    """Entry point: one-line errors, exit 2 on a user mistake, 130 on Ctrl-C."""
    try:
        args = parse(sys.argv[1:] if argv is None else argv)
        lock = use_domain(args)  # held for the whole run
        try:
            cfg = config(args)
            with live_view(cfg.live_port, cfg.namespace, cfg.interface, say,
                           wait_s=cfg.live_wait_s):  # the run's lifetime
                return run(cfg)
        finally:
            if lock is not None:
                lock.close()
    except MsdBenchError as exc:
        print(f"bench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted; node processes stopped", file=sys.stderr)
        return 130
