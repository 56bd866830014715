"""What an in-process run writes once its parts are done: Table 1, robustness and figures.

Each group of files is one task of the run directory (``io/storage/run_dir.py``), so a
run that died while writing is resumed without rewriting what it had finished,
and ``complete`` is written only after the last group. The models and policies
are the part tasks' own files (:mod:`msd_bench.app.paper_tasks`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from msd_bench.app.pipeline import PaperRun
from msd_bench.core.evaluation.results import AgentResult
from msd_bench.io.reports.html_report import write_index
from msd_bench.io.reports.report import write_report, write_robustness
from msd_bench.io.storage.run_dir import RunDir
from msd_bench.io.storage.run_output import FigureData, write_figures


def figure_data(run: PaperRun) -> FigureData:
    """The figures' inputs from an in-process run (first identification seed)."""
    first = min(run.models) if run.models else None
    return FigureData(
        target=run.config.target, dt=run.config.plant.dt,
        models=run.models.get(first, {}) if first is not None else {},
        fits=run.fits.get(first, {}) if first is not None else {},
        records=run.records.get(first) if first is not None else None,
        policies={k: by_id[min(by_id)] for k, by_id in run.policies.items() if by_id},
        responses=run.responses)


def write_reports(rd: RunDir, run: PaperRun, run_facts: Mapping[str, Any],
                  results: Sequence[AgentResult] | None = None, with_figures: bool = True) -> list[str]:
    """Table 1, robustness, figures and ``index.html`` of an in-process run as the last tasks of ``rd``
    (its models and policies were written by its part tasks, :mod:`msd_bench.app.paper_tasks`);
    returns the tasks written now. The task ids are ``commands/paper.py: paper_tasks``."""
    out = rd.root
    rows = results or run.results
    rd.run_task("table1", lambda: list(write_report(out, rows, run_facts, root=out).values()))
    labels = {r.kind: r.label for r in run.results}
    rd.run_task("robustness", lambda: list(write_robustness(out, run.robustness, labels, root=out).values())
                if run.robustness else [])
    if with_figures:
        rd.run_task("figures", lambda: write_figures(out / "figures", figure_data(run), root=out))
    rd.run_task("index", lambda: [write_index(out, root=out, title=f"msd-bench paper run {out.name}")])
    return list(rd.written)
