"""``msd-bench efficiency``: the data-efficiency curve (success vs real-plant samples per route).

Writes ``efficiency.json`` (schema ``msd-bench/efficiency``:
``{"methods": [{"name", "label", "points": [{"real_samples", "n", "n_success", "ci95"}]}]}``)
and ``efficiency.png`` under ``--out``, and prints where each route reaches the
on-plant learner's final success rate. ``--out`` is a run directory
(docs/design.md §Runs on disk): each route is a task with its points in
``routes/``, so an interrupted sweep resumes without redoing a finished route.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import add_run_arguments, run_config_from_args
from msd_bench.commands.paper import run_config_doc

if TYPE_CHECKING:
    from msd_bench.app.efficiency import EfficiencyConfig
    from msd_bench.io.run_dir import RunDir


def register(sub: Any) -> None:
    """Add the ``efficiency`` subcommand."""
    p = sub.add_parser("efficiency", help="success rate against real-plant samples, per route",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    from msd_bench.app.efficiency import PLANT_AGENTS, SURROGATE_AGENTS

    add_run_arguments(p, seeds=20, id_seeds=2, agents=(*SURROGATE_AGENTS, *PLANT_AGENTS))
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--record-samples", default="300,1000,2500,6000,12000",
                   help="samples per identification record at each surrogate-route point")
    p.add_argument("--budgets", default="10,30,100,300",
                   help="on-plant training budgets, in episodes of --steps steps")
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


ROUTE_TASKS = {"surrogate-route": "routes/surrogate.json", "plant-route": "routes/plant.json"}
"""One task per route, each a file of its points: a resumed sweep does not redo a finished route."""
TASKS = [*ROUTE_TASKS, "efficiency"]


def run(args: argparse.Namespace) -> int:
    """Probe --out, sweep each route as a task, write the JSON and the figure, print the crossing points."""
    from msd_bench.app.efficiency import EfficiencyConfig, crossings
    from msd_bench.io.run_dir import RunDir, RunDirError
    from msd_bench.io.safe_read import read_json_bounded

    run_cfg = run_config_from_args(args)
    cfg = EfficiencyConfig(run_cfg, surrogate_agents=tuple(run_cfg.surrogate_agents()),
                           plant_agents=tuple(run_cfg.plant_agents()),
                           record_samples=_ints(args.record_samples, "--record-samples"),
                           episodes=_ints(args.budgets, "--budgets"))
    config = run_config_doc(run_cfg, record_samples=list(cfg.record_samples), episodes=list(cfg.episodes),
                            surrogate_agents=list(cfg.surrogate_agents), plant_agents=list(cfg.plant_agents))
    rd = RunDir.open(Path(args.out), "efficiency", TASKS, config)  # before any work
    if rd.pending():  # a run that died after its files but before the marker needs no new work
        _sweep(rd, cfg)
    rd.mark_complete()
    for line in crossings(read_json_bounded(rd.root / "efficiency.json", RunDirError)["methods"]):
        print(line)
    print(f"report: {rd.root}", file=sys.stderr)
    return 0


def _sweep(rd: RunDir, cfg: EfficiencyConfig) -> None:
    """The routes not swept yet, then ``efficiency.json`` and its figure from both routes' files."""
    from msd_bench.app import efficiency as eff
    from msd_bench.io.atomic import write_text_atomic
    from msd_bench.io.figures import efficiency_figure
    from msd_bench.io.run_dir import RunDirError
    from msd_bench.io.safe_read import read_json_bounded
    from msd_bench.progress import StageProgress

    points = {"surrogate-route": eff.surrogate_points, "plant-route": eff.plant_points}
    with StageProgress("efficiency") as bar:
        for task, rel in ROUTE_TASKS.items():
            def sweep(task: str = task, rel: str = rel) -> list[Path]:
                doc = points[task](cfg, bar.update)
                return [write_text_atomic(rd.root / rel, json.dumps(doc, indent=1) + "\n", root=rd.root)]

            rd.run_task(task, sweep)
    lines = {k: v for rel in ROUTE_TASKS.values()
             for k, v in read_json_bounded(rd.root / rel, RunDirError).items()}
    doc = eff.document(lines)
    rd.run_task("efficiency", lambda: [
        write_text_atomic(rd.root / "efficiency.json", json.dumps(doc, indent=1) + "\n", root=rd.root),
        efficiency_figure(rd.root / "efficiency.png", doc["methods"], root=rd.root)])
