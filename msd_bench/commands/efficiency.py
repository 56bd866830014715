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
"""

from __future__ import annotations

import argparse
import json
import sys
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

if TYPE_CHECKING:
    from msd_bench.app.efficiency import EfficiencyConfig
    from msd_bench.app.executor import ExecutorOptions
    from msd_bench.io.storage.run_dir import RunDir


def register(sub: Any) -> None:
    """Add the ``efficiency`` subcommand."""
    p = sub.add_parser("efficiency", help="success rate against real-plant samples, per route",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    from msd_bench.app.efficiency import PLANT_AGENTS, SURROGATE_AGENTS

    add_run_arguments(p, seeds=20, id_seeds=2, agents=(*SURROGATE_AGENTS, *PLANT_AGENTS))

    add_supervisor_argument(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--record-samples", default="300,1000,2500,6000,12000",
                   help="samples per identification record at each surrogate-route point")
    p.add_argument("--budgets", default="10,30,100,300",
                   help="on-plant training budgets, in episodes of --steps steps")
    add_executor_arguments(p)
    p.set_defaults(func=run)


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

    run_cfg = run_config_from_args(args)
    return EfficiencyConfig(run_cfg, surrogate_agents=tuple(run_cfg.surrogate_agents()),
                            plant_agents=tuple(run_cfg.plant_agents()),
                            record_samples=_ints(args.record_samples, "--record-samples"),
                            episodes=_ints(args.budgets, "--budgets"))


def efficiency_tasks(cfg: EfficiencyConfig) -> list[str]:
    """The tasks of an ``efficiency`` run directory in writing order: every point, then the report."""
    return [*point_ids(cfg), "efficiency"]


def run(args: argparse.Namespace) -> int:
    """Probe --out, sweep the points not written yet, write the JSON and the figure, print the crossings."""
    from msd_bench.app.efficiency import crossings
    from msd_bench.io.storage.run_dir import RunDir, RunDirError
    from msd_bench.io.storage.safe_read import read_json_bounded

    cfg = efficiency_config(args)
    options = executor_from_args(args)
    config = run_config_doc(cfg.run, record_samples=list(cfg.record_samples), episodes=list(cfg.episodes),
                            surrogate_agents=list(cfg.surrogate_agents), plant_agents=list(cfg.plant_agents))
    rd = RunDir.open(Path(args.out), "efficiency", efficiency_tasks(cfg), config)  # before work
    if rd.pending():  # a run that died after its files but before the marker needs no new work
        _sweep(rd, cfg, options)
    rd.mark_complete()
    for line in crossings(read_json_bounded(rd.root / "efficiency.json", RunDirError)["methods"]):
        print(line)
    print(f"report: {rd.root}", file=sys.stderr)
    return 0


def point_ids(cfg: EfficiencyConfig) -> list[str]:
    """Every point's task id, surrogate route first."""
    from msd_bench.app import efficiency as eff

    return [t[0] for t in eff.surrogate_tasks(cfg)] + [t[0] for t in eff.plant_tasks(cfg)]


def _sweep(rd: RunDir, cfg: EfficiencyConfig, options: ExecutorOptions) -> None:
    """The points not swept yet (on the executor), then ``efficiency.json`` and its figure from all."""
    from msd_bench.app import efficiency as eff
    from msd_bench.app.executor import Task
    from msd_bench.app.sweep import run_sweep
    from msd_bench.io.reports.figures import efficiency_figure
    from msd_bench.io.reports.html_report import write_index
    from msd_bench.io.storage.atomic import write_text_atomic
    from msd_bench.io.storage.run_dir import RunDirError
    from msd_bench.io.storage.safe_read import read_json_bounded
    from msd_bench.progress import StageProgress

    tasks = [Task(tid, eff.surrogate_point, (cfg, n, j)) for tid, n, j in eff.surrogate_tasks(cfg)]
    tasks += [Task(tid, eff.plant_point, (cfg, e, kind)) for tid, e, kind in eff.plant_tasks(cfg)]

    def write_point(task: Task, result: Any) -> list[Path]:
        text = json.dumps(result, indent=1) + "\n"
        return [write_text_atomic(rd.root / f"points/{task.id}.json", text, root=rd.root)]

    with StageProgress("efficiency") as bar:
        done = [0]

        def tick(task: Task) -> None:
            done[0] += 1
            bar.update(task.id, done[0], len(tasks))

        run_sweep(rd, tasks, write_point, options, bar.say, on_written=tick)
    parts = {t.id: read_json_bounded(rd.root / f"points/{t.id}.json", RunDirError) for t in tasks}
    doc = eff.document({**eff.surrogate_lines(cfg, parts), **eff.plant_lines(cfg, parts)})
    rd.run_task("efficiency", lambda: [
        write_text_atomic(rd.root / "efficiency.json", json.dumps(doc, indent=1) + "\n", root=rd.root),
        efficiency_figure(rd.root / "efficiency.png", doc["methods"], root=rd.root),
        write_index(rd.root, root=rd.root, title=f"msd-bench efficiency run {rd.root.name}")])
