"""``msd-bench efficiency``: the data-efficiency curve (success vs real-plant samples per route).

Writes ``efficiency.json`` (schema ``msd-bench/efficiency``:
``{"methods": [{"name", "label", "points": [{"real_samples", "n", "n_success", "ci95"}]}]}``)
and ``efficiency.png`` (and ``index.html``, the page of both) under ``--out``,
and prints where each route reaches the on-plant learner's final success rate. ``--out`` is a run directory
(docs/design.md §Runs on disk): each point (a record length at one
identification seed, or an on-plant kind at one budget) is a task with its
result in ``points/``, computed by the executor's workers (``--executor
local|ray``, docs/cluster.md) and written by this process as it arrives, so an
interrupted sweep resumes without redoing a finished point.

With ``--rigs N`` (or ``--family``) the curve is drawn on a population of rigs
instead of the ideal plant (:mod:`msd_bench.app.rig_efficiency`): each point is
one record length on one rig, charged what the rig owner spends (records,
settle segments and the rests before them), pooled over rigs with a bootstrap
over rigs. Its defaults are those of ``msd-bench rigs``: 4 learning seeds, one
identification per rig, the robust agents on three surrogates.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import (
    add_executor_arguments,
    add_run_arguments,
    add_supervisor_argument,
    executor_from_args,
    run_config_from_args,
)
from msd_bench.commands.paper import run_config_doc
from msd_bench.designs import kinds

if TYPE_CHECKING:
    from msd_bench.app.efficiency import EfficiencyConfig
    from msd_bench.app.executor import ExecutorOptions, Task
    from msd_bench.app.rig_efficiency import RigEfficiencyConfig
    from msd_bench.io.storage.run_dir import RunDir


def register(sub: Any) -> None:
    """Add the ``efficiency`` subcommand."""
    p = sub.add_parser("efficiency", help="success rate against real-plant samples, per route",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    from msd_bench.app.efficiency import PLANT_AGENTS, SURROGATE_AGENTS

    add_run_arguments(p, seeds=20, id_seeds=2, agents=(*SURROGATE_AGENTS, *PLANT_AGENTS))
    p.set_defaults(seeds=None, id_seeds=None, agents=None)  # the ideal plant's or the rigs' (_defaults)

    add_supervisor_argument(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--record-samples", default="300,1000,2500,6000,12000",
                   help="samples per identification record at each surrogate-route point")
    p.add_argument("--budgets", default=DEFAULT_BUDGETS,
                   help="on-plant training budgets, in episodes of --steps steps")
    _add_rig_arguments(p)
    add_executor_arguments(p)
    p.set_defaults(func=run)


def _add_rig_arguments(p: argparse.ArgumentParser) -> None:
    """``--rigs``, ``--family``, ``--first-rig``, ``--design``, ``--bootstrap``: the curve on rigs."""
    from msd_bench.app.rig_efficiency import FAMILIES
    from msd_bench.core.rigs.population import HELD_OUT_RIGS
    from msd_bench.core.rigs.rig_stats import DEFAULT_RESAMPLES

    g = p.add_argument_group("on a rig population (instead of the ideal plant)")
    g.add_argument("--rigs", type=int, default=None,
                   help="draw the curve on this many rigs (defaults then: --seeds 4, --id-seeds 1, --agents "
                        f"{','.join(RIG_DEFAULTS['agents'])})")
    g.add_argument("--family", default=None, help=f"rig family, one of {', '.join(FAMILIES)} (implies --rigs "
                   f"{DEFAULT_RIGS} unless given)")
    g.add_argument("--first-rig", type=int, default=HELD_OUT_RIGS.start,
                   help=f"seed of the first rig ({HELD_OUT_RIGS.start}, the first held-out rig)")
    g.add_argument("--design", action="store_true", help="run design rigs (seeds below the held-out range)")
    g.add_argument("--bootstrap", type=int, default=DEFAULT_RESAMPLES,
                   help=f"bootstrap-over-rigs resamples ({DEFAULT_RESAMPLES})")
    g.add_argument("--refine", type=int, default=0,
                   help="also the refined route: R rounds of re-identification from the closed-loop tries "
                        "(as msd-bench rigs --refine; 0); on-plant learners in --agents (plant, dyna-q) "
                        "are trained on each rig itself at every --budgets")


DEFAULT_BUDGETS = "10,30,100,300"
"""The on-plant route's budgets, in episodes (the ideal plant's curve only)."""
PLANT_DEFAULTS: dict[str, Any] = {"seeds": 20, "id_seeds": 2}
"""The ideal plant's curve: 20 learning seeds at each of 2 identification seeds (agents: both routes)."""
RIG_DEFAULTS: dict[str, Any] = {"seeds": 4, "id_seeds": 1, "agents": kinds.RIG_EFFICIENCY}
"""The curve on rigs, as ``msd-bench rigs``: 4 learning seeds, one identification per rig."""
DEFAULT_RIGS = 20
"""Rigs of a ``--family`` run without ``--rigs``."""


def on_rigs(args: argparse.Namespace) -> bool:
    """Whether the curve is drawn on rigs (``--rigs`` or ``--family`` given)."""
    return args.rigs is not None or args.family is not None


def _defaults(args: argparse.Namespace) -> argparse.Namespace:
    """``args`` with the options left unset filled from the ideal plant's or the rigs' defaults."""
    from msd_bench.app.efficiency import PLANT_AGENTS, SURROGATE_AGENTS

    base = RIG_DEFAULTS if on_rigs(args) else {**PLANT_DEFAULTS, "agents": (*SURROGATE_AGENTS, *PLANT_AGENTS)}
    filled = argparse.Namespace(**vars(args))
    for name, value in base.items():
        if getattr(filled, name) is None:
            setattr(filled, name, ",".join(value) if name == "agents" else value)
    if on_rigs(args):
        filled.family = args.family or "default"
        filled.rigs = DEFAULT_RIGS if args.rigs is None else args.rigs
    return filled


def _ints(text: str, option: str) -> tuple[int, ...]:
    from msd_bench.core.errors import ConfigError

    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ConfigError(f"{option} must be comma-separated whole numbers, got {text!r}") from None
    if not values:
        raise ConfigError(f"{option} must not be empty")
    return values


def efficiency_config(args: argparse.Namespace) -> EfficiencyConfig:
    """The validated sweep from parsed options (one-line ConfigError otherwise)."""
    from msd_bench.app.efficiency import EfficiencyConfig

    run_cfg = run_config_from_args(_defaults(args))
    return EfficiencyConfig(run_cfg, surrogate_agents=tuple(run_cfg.surrogate_agents()),
                            plant_agents=tuple(run_cfg.plant_agents()),
                            record_samples=_ints(args.record_samples, "--record-samples"),
                            episodes=_ints(args.budgets, "--budgets"))


def efficiency_tasks(cfg: EfficiencyConfig) -> list[str]:
    """The tasks of an ``efficiency`` run directory in writing order: every point, then the report."""
    return [*point_ids(cfg), "efficiency"]


def rig_efficiency_tasks(cfg: RigEfficiencyConfig) -> list[str]:
    """The tasks of an ``efficiency --rigs`` run directory in writing order: every point, then the report."""
    return [*(t.id for t in _rig_tasks(cfg)), "efficiency"]


def rig_efficiency_config(args: argparse.Namespace) -> RigEfficiencyConfig:
    """The validated sweep on rigs from parsed options (one-line ConfigError otherwise)."""
    from dataclasses import replace

    from msd_bench.app.rig_efficiency import RigEfficiencyConfig
    from msd_bench.app.rigs import RigsConfig
    from msd_bench.core.errors import ConfigError

    filled = _defaults(args)
    run_cfg = run_config_from_args(filled)
    on_model, on_plant = kinds.split_by_model(run_cfg.agents)
    if not on_model:
        raise ConfigError("the curve on rigs draws on-plant learners beside a surrogate route: add a kind "
                          f"on an identified model to --agents (e.g. {kinds.RIG_EFFICIENCY[-1]})")
    rigs = RigsConfig(replace(run_cfg, agents=tuple(on_model)), rigs=filled.rigs, first_rig=args.first_rig,
                      design=args.design, scenarios=(), resamples=args.bootstrap, refine=args.refine,
                      family=filled.family)
    return RigEfficiencyConfig(rigs, record_samples=_ints(args.record_samples, "--record-samples"),
                               family=filled.family, plant_agents=tuple(on_plant),
                               episodes=_ints(args.budgets, "--budgets"))


def run(args: argparse.Namespace) -> int:
    """Probe --out, sweep the points not written yet, write the JSON and the figure, print the crossings."""
    from msd_bench.app import efficiency as eff
    from msd_bench.app.executor import Task
    from msd_bench.io.storage.run_dir import RunDir, RunDirError
    from msd_bench.io.storage.safe_read import read_json_bounded

    options = executor_from_args(args)
    if on_rigs(args):
        rcfg = rig_efficiency_config(args)
        config = run_config_doc(rcfg.rigs.run, record_samples=list(rcfg.record_samples), family=rcfg.family,
                                rigs=rcfg.rigs.rig_seeds(), design=rcfg.rigs.design,
                                resamples=rcfg.rigs.resamples, refine=rcfg.rigs.refine)
        tasks = _rig_tasks(rcfg)
        make_doc = _rig_document(rcfg)
    else:
        _refuse_rig_options(args)
        cfg = efficiency_config(args)
        config = run_config_doc(cfg.run, record_samples=list(cfg.record_samples), episodes=list(cfg.episodes),
                                surrogate_agents=list(cfg.surrogate_agents),
                                plant_agents=list(cfg.plant_agents))
        tasks = [Task(tid, eff.surrogate_point, (cfg, n, j)) for tid, n, j in eff.surrogate_tasks(cfg)]
        tasks += [Task(tid, eff.plant_point, (cfg, e, kind)) for tid, e, kind in eff.plant_tasks(cfg)]

        def make_doc(parts: dict[str, Any]) -> dict[str, Any]:
            return eff.document({**eff.surrogate_lines(cfg, parts), **eff.plant_lines(cfg, parts)})

    ids = [*(t.id for t in tasks), "efficiency"]
    rd = RunDir.open(Path(args.out), "efficiency", ids, config)  # before work
    if rd.pending():  # a run that died after its files but before the marker needs no new work
        _sweep(rd, tasks, make_doc, options)
    rd.mark_complete()
    methods = read_json_bounded(rd.root / "efficiency.json", RunDirError)["methods"]
    for line in ([] if on_rigs(args) else eff.crossings(methods)):  # on rigs: no on-plant reference
        print(line)
    print(f"report: {rd.root}", file=sys.stderr)
    return 0


def _refuse_rig_options(args: argparse.Namespace) -> None:
    """Options of the curve on rigs given without ``--rigs``/``--family``: one line, not ignored."""
    from msd_bench.core.errors import ConfigError
    from msd_bench.core.rigs.population import HELD_OUT_RIGS
    from msd_bench.core.rigs.rig_stats import DEFAULT_RESAMPLES

    set_ = (("--design", args.design), ("--first-rig", args.first_rig != HELD_OUT_RIGS.start),
            ("--bootstrap", args.bootstrap != DEFAULT_RESAMPLES), ("--refine", args.refine != 0))
    given = [opt for opt, on in set_ if on]
    if given:
        raise ConfigError(f"{', '.join(given)} apply to the curve on rigs: add --rigs N or --family NAME")


def _rig_tasks(cfg: RigEfficiencyConfig) -> list[Task]:
    from msd_bench.app.executor import Task
    from msd_bench.app.rig_efficiency import plant_tasks, rig_plant_point, rig_point, tasks

    return [*(Task(tid, rig_point, (cfg, n, seed)) for tid, n, seed in tasks(cfg)),
            *(Task(tid, rig_plant_point, (cfg, e, kind, seed)) for tid, e, kind, seed in plant_tasks(cfg))]


def _rig_document(cfg: RigEfficiencyConfig) -> Callable[[dict[str, Any]], dict[str, Any]]:
    from msd_bench.app.rig_efficiency import document

    return lambda parts: document(cfg, parts)


def point_ids(cfg: EfficiencyConfig) -> list[str]:
    """Every point's task id, surrogate route first."""
    from msd_bench.app import efficiency as eff

    return [t[0] for t in eff.surrogate_tasks(cfg)] + [t[0] for t in eff.plant_tasks(cfg)]


def _sweep(rd: RunDir, tasks: list[Task], make_doc: Callable[[dict[str, Any]], dict[str, Any]],
           options: ExecutorOptions) -> None:
    """The points not swept yet (on the executor), then ``efficiency.json`` and its figure from all."""
    from msd_bench.app.sweep import run_sweep
    from msd_bench.io.reports.figures import efficiency_figure
    from msd_bench.io.reports.html_report import write_index
    from msd_bench.io.storage.artifacts import jsonable
    from msd_bench.io.storage.atomic import write_text_atomic
    from msd_bench.io.storage.run_dir import RunDirError
    from msd_bench.io.storage.safe_read import read_json_bounded
    from msd_bench.progress import StageProgress

    def write_point(task: Task, result: Any) -> list[Path]:
        text = json.dumps(jsonable(result), indent=1) + "\n"
        return [write_text_atomic(rd.root / f"points/{task.id}.json", text, root=rd.root)]

    with StageProgress("efficiency") as bar:
        done = [0]

        def tick(task: Task) -> None:
            done[0] += 1
            bar.update(task.id, done[0], len(tasks))

        run_sweep(rd, tasks, write_point, options, bar.say, on_written=tick)
    parts = {t.id: read_json_bounded(rd.root / f"points/{t.id}.json", RunDirError) for t in tasks}
    doc = make_doc(parts)
    rd.run_task("efficiency", lambda: [
        write_text_atomic(rd.root / "efficiency.json", json.dumps(doc, indent=1) + "\n", root=rd.root),
        efficiency_figure(rd.root / "efficiency.png", doc["methods"], root=rd.root),
        write_index(rd.root, root=rd.root, title=f"msd-bench efficiency run {rd.root.name}")])
