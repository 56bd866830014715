"""What an in-process run writes: Table 1, robustness, models, Q-tables and figures."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from msd_bench.app.pipeline import PaperRun
from msd_bench.core.results import AgentResult
from msd_bench.io import artifacts
from msd_bench.io.report import write_report, write_robustness
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


def write_all(out_dir: Path, run: PaperRun, run_facts: Mapping[str, Any],
              results: Sequence[AgentResult] | None = None, with_figures: bool = True) -> dict[str, Any]:
    """Report, models, Q-tables and figures of an in-process run under ``out_dir``."""
    out_dir = Path(out_dir)
    prov = artifacts.Provenance(parameters=dict(run_facts), seed=run.config.first_seed)
    written: dict[str, Any] = {"report": write_report(out_dir, results or run.results, run_facts)}
    if run.robustness:
        labels = {r.kind: r.label for r in run.results}
        written["robustness"] = write_robustness(out_dir, run.robustness, labels)
    for id_seed, models in run.models.items():
        written[f"models_id{id_seed}"] = write_models(
            out_dir / "models" / f"id{id_seed}", models, run.fits[id_seed], prov)
    written["qtables"] = write_qtables(out_dir / "qtables", run.qtables, dict(run_facts))
    if with_figures:
        written["figures"] = write_figures(out_dir / "figures", figure_data(run))
    return written
