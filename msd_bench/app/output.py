"""What an in-process run writes: Table 1, robustness, models, Q-tables and figures.

Each group of files is one task of the run directory (``io/run_dir.py``), so a
run that died while writing is resumed without rewriting what it had finished,
and ``complete`` is written only after the last group.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from msd_bench.app.pipeline import PaperRun
from msd_bench.core.results import AgentResult
from msd_bench.io import artifacts
from msd_bench.io.report import write_report, write_robustness
from msd_bench.io.run_dir import RunDir
from msd_bench.io.run_output import FigureData, write_figures, write_models, write_qtables


def figure_data(run: PaperRun) -> FigureData:
    """The figures' inputs from an in-process run (first identification seed)."""
    first = min(run.models) if run.models else None
    return FigureData(
        target=run.config.target, dt=run.config.plant.dt,
        models=run.models.get(first, {}) if first is not None else {},
        fits=run.fits.get(first, {}) if first is not None else {},
        records=run.records.get(first) if first is not None else None,
        qtables=run.qtables, responses=run.responses)


def write_all(rd: RunDir, run: PaperRun, run_facts: Mapping[str, Any],
              results: Sequence[AgentResult] | None = None, with_figures: bool = True) -> list[str]:
    """Report, models, Q-tables and figures of an in-process run as the tasks of ``rd``; returns the
    tasks written now (the others were done by an earlier attempt of the same run).

    The task ids are ``commands/paper.py: paper_tasks``. Files of a task that died half-way are the
    run's own, so a task may replace them (``overwrite``).
    """
    out = rd.root
    prov = artifacts.Provenance(parameters=dict(run_facts), seed=run.config.first_seed)
    rows = results or run.results
    rd.run_task("table1", lambda: list(write_report(out, rows, run_facts, root=out).values()))
    labels = {r.kind: r.label for r in run.results}
    rd.run_task("robustness", lambda: list(write_robustness(out, run.robustness, labels, root=out).values())
                if run.robustness else [])
    for id_seed in run.config.id_seed_values():
        rd.run_task(f"models-id{id_seed}", _models_task(rd, run, id_seed, prov))
    rd.run_task("qtables", lambda: list(write_qtables(out / "qtables", run.qtables, dict(run_facts),
                                                      root=out, overwrite=True).values()))
    if with_figures:
        rd.run_task("figures", lambda: write_figures(out / "figures", figure_data(run), root=out))
    return list(rd.written)


def _models_task(rd: RunDir, run: PaperRun, id_seed: int,
                 prov: artifacts.Provenance) -> Callable[[], list[Path]]:
    """The task writing one identification seed's models (a function, so each seed keeps its own)."""
    def produce() -> list[Path]:
        return list(write_models(rd.root / "models" / f"id{id_seed}", run.models.get(id_seed, {}),
                                 run.fits.get(id_seed, {}), prov, root=rd.root, overwrite=True).values())
    return produce
