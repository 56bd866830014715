"""``msd-bench rigs``: the whole method on each rig of a population, in-process (docs/rigs.md).

Per rig: the paper's experiment plan played through it (rest without reset),
every model kind identified from those records only, each agent kind trained
on its surrogate and validated through the rig's own actuator and sensor.
Writes ``rigs.json`` (schema ``msd-bench/rigs``), ``rigs.md`` (from rigs.json
only), ``rigs.png`` and ``index.html`` (their page) under ``--out``, a run directory (docs/design.md §Runs
on disk): each rig is a task with its result in ``rigs/``, computed by the
executor's workers (``--executor local|ray``) and written as it arrives, so an
interrupted sweep resumes without redoing a finished rig. Held-out rigs by
default; ``--design`` runs design rigs, and the two seed ranges never mix.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import (
    add_executor_arguments,
    add_run_arguments,
    add_supervisor_argument,
    executor_from_args,
    run_config_from_args,
)

if TYPE_CHECKING:
    from msd_bench.app.executor import ExecutorOptions
    from msd_bench.app.rigs import RigsConfig
    from msd_bench.core.rigs.units import RigUnits
    from msd_bench.io.storage.run_dir import RunDir


def register(sub: Any) -> None:
    """Add the ``rigs`` subcommand."""
    from msd_bench.app.rigs import ACTUATOR_CHOICES, DEFAULT_AGENTS, RIG_SCENARIOS
    from msd_bench.core.rigs.families import DEFAULT_FAMILY, FAMILIES
    from msd_bench.core.rigs.population import HELD_OUT_RIGS
    from msd_bench.core.rigs.rig_stats import DEFAULT_RESAMPLES

    p = sub.add_parser("rigs", help="the whole method on each rig of a population",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p, seeds=4, agents=DEFAULT_AGENTS)
    add_supervisor_argument(p)
    p.add_argument("--family", default=DEFAULT_FAMILY,
                   help=f"the rig family to draw, one of {', '.join(FAMILIES)} ({DEFAULT_FAMILY}; "
                        "docs/rig-families.md)")
    p.add_argument("--rig", type=Path, metavar="FILE", default=None,
                   help="rig description (docs/rig-description.md): every rig of the family carried into "
                        "its units (stroke, force limit, sample time), as a population around that rig")
    p.add_argument("--rigs", type=int, default=20, help="rigs in the run (20)")
    p.add_argument("--first-rig", type=int, default=HELD_OUT_RIGS.start,
                   help=f"seed of the first rig ({HELD_OUT_RIGS.start}, the first held-out rig)")
    p.add_argument("--design", action="store_true", help="run design rigs (seeds below the held-out range)")
    p.add_argument("--rig-scenarios", default=",".join(RIG_SCENARIOS).replace(",", ";"),
                   help="';'-separated set-point/load scenarios run on every rig after the nominal run "
                        "('' for none)")
    p.add_argument("--bootstrap", type=int, default=DEFAULT_RESAMPLES,
                   help=f"bootstrap-over-rigs resamples ({DEFAULT_RESAMPLES})")
    p.add_argument("--robust-actuator", default="measured",
                   help="what the robust agent's observer is told of each rig's drive, one of "
                        f"{', '.join(ACTUATOR_CHOICES)}: the delay fitted between its broad record's "
                        "commands and effort (measured, the default) or none (the agent as chosen on "
                        "the ideal plant)")
    p.add_argument("--ceiling", action="store_true",
                   help="also run the ceiling: the robust agent trained on each rig's own simulator "
                        "(its true plant, friction and drive) and on its true plant told its true delay, "
                        "validated after every agent kind")
    p.add_argument("--refine", type=int, default=0,
                   help="refinement rounds on the rig per kind fitted from the broad record: try behind "
                        "the supervisor, refit from the open-loop and closed-loop records, retrain, try "
                        "again; keep the best measured try; a fresh validation is reported (0: none)")
    p.add_argument("--refine-weight", type=int, default=1,
                   help="times each closed-loop record enters a refit beside the broad record (1)")
    p.add_argument("--out", type=Path, required=True, help="output run directory (created)")
    add_executor_arguments(p)
    p.set_defaults(func=run)


def rigs_config(args: argparse.Namespace) -> RigsConfig:
    """The validated population run from parsed options (one-line ConfigError otherwise)."""
    from msd_bench.app.rigs import RigsConfig

    scenarios = tuple(s.strip() for s in str(args.rig_scenarios).split(";") if s.strip())
    return RigsConfig(run_config_from_args(args), rigs=args.rigs, first_rig=args.first_rig,
                      design=args.design, scenarios=scenarios, resamples=args.bootstrap,
                      actuator=args.robust_actuator, ceiling=args.ceiling,
                      refine=args.refine, refine_weight=args.refine_weight, family=args.family,
                      units=described_units(getattr(args, "rig", None)))


def described_units(path: Path | None) -> RigUnits | None:
    """The units of ``--rig FILE`` against the default plant (None without it). A rig deciding less
    often than it samples is refused in one line: the population's closed loops act every sample."""
    if path is None:
        return None
    from msd_bench.core.errors import ConfigError
    from msd_bench.core.rigs.units import units_between
    from msd_bench.io.rigs.rig_file import read_rig

    rig = read_rig(path)
    if rig.samples_per_decision != 1:
        raise ConfigError(f"--rig {path}: decision_period is {rig.samples_per_decision} samples; rigs "
                          "runs every rig's closed loop every sample (give decision_period = 1/rate)")
    return units_between(rig.stroke, rig.force_limit, rig.dt)


def routes_doc(cfg: RigsConfig) -> dict[str, Any]:
    """What the manifest adds for the ceiling and refinement (nothing without them: a run directory
    written before they existed resumes as it was)."""
    extra: dict[str, Any] = {"ceiling": True} if cfg.ceiling else {}
    if cfg.family != "default":  # the default family's manifest is as it was: its run directories resume
        extra["family"] = cfg.family
    if cfg.units is not None:
        extra["units"] = [cfg.units.length, cfg.units.mass, cfg.units.time]
    if cfg.refine:
        extra.update(refine=cfg.refine, refine_weight=cfg.refine_weight)
    return extra


def task_id(seed: int) -> str:
    """The run-directory task of rig ``seed``."""
    return f"rig-{seed}"


def rigs_tasks(cfg: RigsConfig) -> list[str]:
    """The tasks of a ``rigs`` run directory in writing order: every rig, then the report."""
    return [*map(task_id, cfg.rig_seeds()), "rigs"]


def run(args: argparse.Namespace) -> int:
    """Probe --out, sweep the rigs not written yet, write rigs.json, rigs.md and the figure."""
    from msd_bench.commands.paper import run_config_doc
    from msd_bench.io.storage.run_dir import RunDir

    cfg = rigs_config(args)
    options = executor_from_args(args)
    config = run_config_doc(cfg.run, rigs=cfg.rig_seeds(), design=cfg.design, scenarios=list(cfg.scenarios),
                            resamples=cfg.resamples, robust_actuator=cfg.actuator, **routes_doc(cfg))
    rd = RunDir.open(Path(args.out), "rigs", rigs_tasks(cfg), config)  # before work
    if rd.pending():
        _sweep(rd, cfg, options)
    rd.mark_complete()
    print((rd.root / "rigs.md").read_text().split("## Scenarios")[0].rstrip())
    print(f"report: {rd.root}", file=sys.stderr)
    return 0


def sweep_facts(options: ExecutorOptions, wall: float, computed: int) -> dict[str, Any]:
    """How this invocation ran: its wall time (the sweep and the report), the rigs it computed (a
    resumed run computes only the rest), the executor and its workers, and the machine's cores."""
    return {"wall_seconds": wall, "rigs_computed": computed, "executor": options.kind,
            "workers": options.workers, "cpus": os.cpu_count()}


def _sweep(rd: RunDir, cfg: RigsConfig, options: ExecutorOptions) -> None:
    """The rigs not done yet (on the executor, a progress bar over rigs), then the report from all."""
    from msd_bench.app.executor import Task
    from msd_bench.app.rigs import document, rig_task
    from msd_bench.app.sweep import run_sweep
    from msd_bench.io.reports.html_report import write_index
    from msd_bench.io.rigs.rig_parts import read_part
    from msd_bench.io.rigs.rigs_figure import rigs_figure
    from msd_bench.io.rigs.rigs_report import write_rigs_markdown
    from msd_bench.io.storage.artifacts import jsonable
    from msd_bench.io.storage.atomic import write_text_atomic
    from msd_bench.progress import StageProgress

    tasks = [Task(task_id(s), rig_task, (cfg, s)) for s in cfg.rig_seeds()]
    started = time.monotonic()

    def write_rig(task: Task, result: Any) -> list[Path]:
        text = json.dumps(jsonable(result), indent=1) + "\n"
        return [write_text_atomic(rd.root / f"rigs/{task.id}.json", text, root=rd.root)]

    with StageProgress("rigs") as bar:
        done = [sum(rd.is_done(t.id) for t in tasks)]
        resumed = done[0]
        bar.update("rigs", done[0], len(tasks))

        def tick(task: Task) -> None:
            done[0] += 1
            bar.update(task.id, done[0], len(tasks))

        run_sweep(rd, tasks, write_rig, options, bar.say, on_written=tick)
    parts = [read_part(rd.root / f"rigs/{task_id(s)}.json", s, cfg.kinds(), cfg.scenarios)
             for s in cfg.rig_seeds()]
    doc = jsonable(document(cfg, parts))
    doc["sweep"] = sweep_facts(options, time.monotonic() - started, len(tasks) - resumed)
    rd.run_task("rigs", lambda: [
        write_text_atomic(rd.root / "rigs.json", json.dumps(doc, indent=1) + "\n", root=rd.root),
        write_rigs_markdown(rd.root / "rigs.md", doc, root=rd.root),
        rigs_figure(rd.root / "rigs.png", doc, root=rd.root),
        write_index(rd.root, root=rd.root, title=f"msd-bench rigs run {rd.root.name}")])
