"""Everything a run writes besides bags: models, policies and the figures.

Shared by ``msd-bench paper`` (in-process) and ``bench.py`` (the ROS graph), so
both produce the same layout. Takes plain data, never the application's run
object, so ``io`` stays below ``app``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.identification.identify import FitReport, free_run
from msd_bench.core.identification.model_kinds import model_kind
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.model import StepModel
from msd_bench.io.reports import figures
from msd_bench.io.storage import artifacts


class Saved(Protocol):
    """A policy as this module sees it (:class:`msd_bench.designs.protocol.Policy`): it saves and
    draws itself, so nothing here knows a design."""

    def save(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool) -> list[Path]:
        """Write its artifact into ``directory``."""

    def figures(self, fig_dir: Path, root: Path) -> list[Path]:
        """Its own figures."""


FAILED_KEY = "failed"
"""The key of ``fits.json`` listing the model kinds that could not be fitted: ``{kind: reason}``
(written by :mod:`msd_bench.app.identification`; bench.py reports those kinds' agents as failed)."""


def write_models(out_dir: Path, models: Mapping[str, StepModel], fits: Mapping[str, FitReport],
                 provenance: artifacts.Provenance, root: Path | None = None,
                 overwrite: bool = False) -> dict[str, Path]:
    """One JSON artifact per surrogate, with its validation fit in ``info``.

    ``root``: the output directory no write may leave; ``overwrite``: the run
    directory vouches the files are its own (a resumed task), see ``save_model``.
    """
    paths = {}
    for name, model in models.items():
        info = {**model.info, "validation_fit": asdict(fits[name])} if name in fits else model.info
        tagged = replace(model, info=info)
        paths[name] = artifacts.save_model(tagged, Path(out_dir) / f"{name}.json", provenance,
                                           root=root, overwrite=overwrite)
    return paths


def qtable_meta(learner: Any, seeds: Any, extra: Mapping[str, Any]) -> dict[str, Any]:
    """Metadata stored with Q-tables: the learner config they were trained with, so no reader guesses it."""
    return {**extra, "seeds": [int(s) for s in seeds], "learner": asdict(learner)}


def write_policies(out_dir: Path, policies: Mapping[str, Mapping[int, Saved]],
                   provenance: artifacts.Provenance, root: Path | None = None,
                   overwrite: bool = False) -> list[Path]:
    """Every policy's artifact under ``<out_dir>/<kind>/id<seed>/`` (``root`` and ``overwrite`` as
    :func:`write_models`): the same files bench.py's agent node writes under ``agents/<kind>/``."""
    root = Path(out_dir) if root is None else root
    paths: list[Path] = []
    for kind, by_id in policies.items():
        for id_seed, policy in by_id.items():
            prov = {**provenance.as_dict(), "id_seed": int(id_seed)}
            paths += policy.save(Path(out_dir) / kind / f"id{id_seed}", prov, root, overwrite)
    return paths


@dataclass(frozen=True)
class FigureData:
    """What the figures of one run show (identification seed 0 for the fits)."""

    target: float
    """Validation set-point, m."""
    dt: float
    """Sample time, s."""
    models: Mapping[str, StepModel] = field(default_factory=dict)
    fits: Mapping[str, FitReport] = field(default_factory=dict)
    records: Records | None = None
    policies: Mapping[str, Saved] = field(default_factory=dict)
    """Per agent kind: the policy that draws its own figures (Q-learners: their first seed's tables)."""
    responses: Mapping[str, NDArray[np.float64]] = field(default_factory=dict)
    """Per agent kind: closed-loop positions on the plant (seeds × steps)."""


def write_figures(fig_dir: Path, data: FigureData, root: Path | None = None) -> list[Path]:
    """Fig. 3–5 (fits), 6/7/11/12 (Q-tables of the first seed), 13 (step responses).

    ``root``: the output directory no write may leave (default ``fig_dir``).
    """
    fig_dir = Path(fig_dir)
    root = fig_dir if root is None else root
    paths: list[Path] = []
    if data.records is not None:
        paths += [_fit_figure(fig_dir, name, m, data.fits.get(name), data.records, root)
                  for name, m in data.models.items()]
    for policy in data.policies.values():
        paths += policy.figures(fig_dir, root)
    if data.responses:
        paths.append(figures.step_response_figure(
            fig_dir / "step_responses.png", data.responses, data.target, data.dt, root=root))
    return paths


def _fit_figure(fig_dir: Path, name: str, model: StepModel, fit: FitReport | None,
                records: Records, root: Path) -> Path:
    """The registry says how a kind is drawn: per bias (the PLM) or on the broad record."""
    if model_kind(name).figure == "bias" and records.bias_val:
        panels = []
        for b, r in records.bias_val.items():
            y, yhat = r.experiments[0].y, free_run(model, r.experiments[0])
            panels.append((f"bias {b:+g} N", y, yhat, fit_percent(y, yhat)))
        return figures.fit_figure(fig_dir / f"fit_{name}.png", f"{name} validation per bias (Fig. 3)",
                                  panels, max_seconds=20.0, root=root)
    broad = records.broad_val.experiments[0]
    yhat = free_run(model, broad)
    score = fit.sim_fit if fit is not None else fit_percent(broad.y, yhat)
    return figures.fit_figure(fig_dir / f"fit_{name}.png", f"{name} free-run validation (Fig. 4/5)",
                              [("broad record", broad.y, yhat, score)], root=root)
