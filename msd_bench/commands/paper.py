"""``msd-bench paper``: the paper's method in-process, over many seeds, as Table 1.

No ROS: records are simulated, models identified, agents trained on their
surrogate and validated on the true plant, all in this process. Writes
``table1.json`` / ``table1.csv`` / ``table1.md`` (schema in the README), the
models, the Q-tables and the figures under ``--out``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import add_run_arguments, run_config_from_args

if TYPE_CHECKING:
    from msd_bench.app.config import RunConfig
    from msd_bench.io.run_dir import RunDir

# The pipeline pulls in torch and python-control (seconds): it is imported when a run
# starts, so `--help` and option errors answer at once.


def register(sub: Any) -> None:
    """Add the ``paper`` subcommand."""
    p = sub.add_parser("paper", help="run the paper's method in-process and print Table 1",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.set_defaults(func=run)


def run_facts(cfg: RunConfig, seconds: float, mode: str) -> dict[str, Any]:
    """What table1.json's ``run`` object records about the run."""

    return {**asdict(cfg), "plant": asdict(cfg.plant), "mode": mode, "seconds": round(seconds, 2),
            "success_sse_percent": 5.0}


def run_config_doc(cfg: RunConfig, **extra: Any) -> dict[str, Any]:
    """The configuration a run directory's manifest records: a rerun resumes only the same one."""
    from msd_bench.io.artifacts import jsonable

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
    """Probe --out, run, write each group of files as a task, mark the run complete, print the table."""
    cfg = run_config_from_args(args)
    figures = not args.no_figures
    from msd_bench.io.run_dir import RunDir

    rd = RunDir.open(Path(args.out), "paper", paper_tasks(cfg, figures), run_config_doc(cfg, figures=figures))
    t0 = time.perf_counter()
    if rd.pending():  # a run that died after its last task but before the marker needs no new work
        from msd_bench.app.output import write_all
        from msd_bench.app.pipeline import run_paper  # torch and control: seconds to import
        from msd_bench.progress import StageProgress

        with StageProgress("paper") as bar:
            result = run_paper(cfg, bar.update)
        write_all(rd, result, run_facts(cfg, time.perf_counter() - t0, "in-process"), with_figures=figures)
    rd.mark_complete()
    print_report(rd, t0)
    return 0


def paper_tasks(cfg: RunConfig, figures: bool) -> list[str]:
    """The tasks of a ``paper`` run directory in writing order (``app/output.py: write_all`` writes them)."""
    models = [f"models-id{s}" for s in cfg.id_seed_values()]
    return ["table1", "robustness", *models, "qtables", *(["figures"] if figures else [])]
