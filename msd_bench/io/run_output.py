"""Everything a run writes besides bags: models, Q-tables, Table 1 and the figures.

Shared by ``msd-bench paper`` (in-process) and ``bench.py`` (the ROS graph), so
both produce the same report layout and the same ``table1.json`` schema.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.core.fit import fit_percent
from msd_bench.core.identify import FitReport, free_run
from msd_bench.core.model import StepModel
from msd_bench.core.pipeline import PaperRun, Records
from msd_bench.core.results import AgentResult
from msd_bench.io import artifacts, figures
from msd_bench.io.report import write_report, write_robustness


def write_models(out_dir: Path, models: Mapping[str, StepModel], fits: Mapping[str, FitReport],
                 provenance: artifacts.Provenance) -> dict[str, Path]:
    """One JSON artifact per surrogate, with its validation fit in ``info``."""
    paths = {}
    for name, model in models.items():
        info = {**model.info, "validation_fit": asdict(fits[name])} if name in fits else model.info
        tagged = StepModel(model.kind, model.params, model.name, info)
        paths[name] = artifacts.save_model(tagged, Path(out_dir) / f"{name}.json", provenance)
    return paths


def write_qtables(out_dir: Path, qtables: Mapping[str, Mapping[str, Any]],
                  meta: Mapping[str, Any]) -> dict[str, Path]:
    """Final tables and first/last-episode snapshots per agent kind (``.npz``)."""
    return {
        kind: artifacts.save_qtables(
            Path(out_dir) / f"{kind}.npz",
            {k: np.asarray(v) for k, v in arrays.items() if k in ("q", "first", "last")},
            {**meta, "agent_kind": kind, **{k: v for k, v in arrays.items() if k == "seeds"}},
        )
        for kind, arrays in qtables.items()
    }


def write_figures(fig_dir: Path, run: PaperRun, id_seed: int = 0) -> list[Path]:
    """Fig. 3–5 (fits), 6/7/11/12 (Q-tables of the first seed), 13 (step responses)."""
    fig_dir = Path(fig_dir)
    paths: list[Path] = []
    models, fits = run.models.get(id_seed, {}), run.fits.get(id_seed, {})
    records = run.records.get(id_seed)
    if records is not None:
        paths += _fit_figures(fig_dir, models, fits, records)
    for kind, arrays in run.qtables.items():
        paths.append(figures.qtable_figure(
            fig_dir / f"qtable_{kind}.png", f"Q-table, {kind} (first seed)",
            arrays["first"][0], arrays["last"][0]))
    if run.responses:
        paths.append(figures.step_response_figure(
            fig_dir / "step_responses.png", run.responses, run.config.target, run.config.plant.dt))
    return paths


def _fit_figures(fig_dir: Path, models: Mapping[str, StepModel], fits: Mapping[str, FitReport],
                 records: Records) -> list[Path]:
    paths = []
    if "plm" in models:
        panels = []
        for b, r in records.bias_val.items():
            y, yhat = r.experiments[0].y, free_run(models["plm"], r.experiments[0])
            panels.append((f"bias {b:+g} N", y, yhat, fit_percent(y, yhat)))
        paths.append(figures.fit_figure(fig_dir / "fit_plm.png", "PLM validation per bias (Fig. 3)",
                                        panels, max_seconds=20.0))
    broad = records.broad_val.experiments[0]
    for name in ("glm", "nlarx-paper", "nlarx-improved"):
        if name in models:
            yhat = free_run(models[name], broad)
            paths.append(figures.fit_figure(
                fig_dir / f"fit_{name}.png", f"{name} free-run validation (Fig. 4/5)",
                [("broad record", broad.y, yhat, fits[name].sim_fit)]))
    return paths


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
        written["figures"] = write_figures(out_dir / "figures", run)
    return written
