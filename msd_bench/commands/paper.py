"""``msd-bench paper``: the paper's method in-process, over many seeds, as Table 1.

No ROS: records are simulated, models identified, agents trained on their
surrogate and validated on the true plant, all in this process. Writes
``table1.json`` / ``table1.csv`` / ``table1.md`` (schema in docs/paper.md), the
models, the trained policies, the figures and ``index.html`` (all of it on one
page) under ``--out``. Each
identification seed (and each on-plant kind) is a task of the executor
(``--executor local|ray``, docs/cluster.md), written as it finishes: a killed
run resumes from the tasks it wrote.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import (
    add_executor_arguments,
    add_run_arguments,
    add_supervisor_argument,
    executor_from_args,
    run_config_from_args,
)
from msd_bench.core.errors import ConfigError

if TYPE_CHECKING:
    from msd_bench.app.config import RunConfig
    from msd_bench.app.executor import ExecutorOptions
    from msd_bench.io.storage.run_dir import RunDir

# The pipeline pulls in torch and python-control (seconds): it is imported when a run
# starts, so `--help` and option errors answer at once.


def register(sub: Any) -> None:
    """Add the ``paper`` subcommand."""
    p = sub.add_parser("paper", help="run the paper's method in-process and print Table 1",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p)
    add_supervisor_argument(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("--rig", type=Path, metavar="FILE",
                   help="run on the emulated plant of this rig description (docs/rig-description.md): its "
                        "rate, stroke and force limit; budgets stay in paper samples of 10 ms")
    add_executor_arguments(p)
    p.set_defaults(func=run)


def on_rig(cfg: RunConfig, path: Path | None) -> RunConfig:
    """``cfg`` on the rig of ``--rig`` (:meth:`RunConfig.on_rig`); one line when the file is bad or the
    rig decides every several samples, which the in-process validation does not do yet (bench.py does)."""
    if path is None:
        return cfg
    from msd_bench.io.rigs.rig_file import read_rig

    rig = read_rig(path)
    if rig.samples_per_decision != 1:
        raise ConfigError(f"--rig {path}: msd-bench paper validates every sample so far; this rig decides "
                          f"every {rig.samples_per_decision} samples (bench.py --rig holds the command "
                          f"between them)")
    return cfg.on_rig(rig)


def run_facts(cfg: RunConfig, seconds: float, mode: str) -> dict[str, Any]:
    """What table1.json's ``run`` object records about the run."""

    return {**asdict(cfg), "plant": asdict(cfg.plant), "mode": mode, "seconds": round(seconds, 2),
            "success_sse_percent": 5.0}


def run_config_doc(cfg: RunConfig, **extra: Any) -> dict[str, Any]:
    """The configuration a run directory's manifest records: a rerun resumes only the same one."""
    from msd_bench.io.storage.artifacts import jsonable

    return {"run": jsonable(asdict(cfg)), **extra}


def print_report(rd: RunDir, started: float) -> None:
    """Table 1 and robustness from the run's files; then where they are (resumed runs say so)."""
    print((rd.root / "table1.md").read_text())
    if (rd.root / "robustness.md").is_file():
        print((rd.root / "robustness.md").read_text())
    if rd.resumed:
        print(f"resumed an unfinished run: {len(rd.tasks) - len(rd.written)} of {len(rd.tasks)} tasks were "
              f"done already", file=sys.stderr)
    print(f"report: {rd.root}  ({time.perf_counter() - started:.0f} s)", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    """Probe --out, run the pending tasks on the executor, write the reports, mark complete, print."""
    cfg = on_rig(run_config_from_args(args), args.rig)
    options = executor_from_args(args)
    figures = not args.no_figures
    from msd_bench.io.storage.run_dir import RunDir

    rd = RunDir.open(Path(args.out), "paper", paper_tasks(cfg, figures), run_config_doc(cfg, figures=figures))
    t0 = time.perf_counter()
    if rd.pending():  # a run that died after its last task but before the marker needs no new work
        from msd_bench.app.output import write_reports
        from msd_bench.app.paper_tasks import load_run

        facts = {**run_facts(cfg, 0.0, "in-process"), "executor": options.kind}
        _run_parts(rd, cfg, options, facts)
        run = load_run(rd, cfg)
        facts["seconds"] = round(time.perf_counter() - t0, 2)
        write_reports(rd, run, facts, with_figures=figures)
    rd.mark_complete()
    print_report(rd, t0)
    return 0


def _run_parts(rd: RunDir, cfg: RunConfig, options: ExecutorOptions, facts: dict[str, Any]) -> None:
    """Every identification seed's and on-plant kind's task not written yet, on the executor."""
    from msd_bench.app import paper_tasks as pt
    from msd_bench.app.executor import Task
    from msd_bench.app.sweep import run_sweep
    from msd_bench.io.storage import artifacts
    from msd_bench.progress import StageProgress

    prov = artifacts.Provenance(parameters=dict(facts), seed=cfg.first_seed)
    fns: dict[str, Callable[..., Any]] = {"identification": pt.identification_part, "plant": pt.plant_part}
    tasks = [Task(tid, fns[what], (cfg, arg)) for tid, what, arg in pt.part_tasks(cfg)]
    with StageProgress("paper") as bar:
        done = [0]

        def tick(task: Task) -> None:
            done[0] += 1
            bar.update(task.id, done[0], len(tasks))

        run_sweep(rd, tasks, lambda task, part: pt.save_part(rd, part, prov), options, bar.say,
                  on_written=tick)


def paper_tasks(cfg: RunConfig, figures: bool) -> list[str]:
    """The tasks of a ``paper`` run directory in writing order: the parts, then the reports
    (``app/output.py: write_reports``)."""
    from msd_bench.app.paper_tasks import part_tasks

    reports = ["table1", "robustness", *(["figures"] if figures else []), "index"]
    return [t for t, _, _ in part_tasks(cfg)] + reports
