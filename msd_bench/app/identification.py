"""Fit model kinds on records and write them: the one path the identifier node and
``msd-bench identify`` share.

Why one function: the node (bags in) and the console command (bags, CSV, NPZ or MAT in)
must write the same files by the same rules — each model as soon as it is fitted, a kind
that cannot be fitted named in ``fits.json`` with its one-line reason while the others are
still fitted and written (:func:`msd_bench.app.pipeline.identify_each`, the mechanism
``msd-bench rigs`` uses), and ``fits.json`` written last, also when a kind failed.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

from msd_bench.app.pipeline import identify_each
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.paths import OutputError
from msd_bench.io.storage.run_output import FAILED_KEY, write_models

_T = TypeVar("_T")


@dataclass(frozen=True)
class IdentifyJob:
    """What to fit and the rig's facts the records do not carry."""

    models: tuple[str, ...]
    """Registered model kinds, fitted in this order."""
    seed: int
    """Seed of the NLARX training."""
    stroke: float
    """Stroke L of the rig (output units): model outputs are projected on [-L/2, L/2]."""
    force: float
    """Input limit F of the rig (input units): inputs saturate at ±F."""
    dt: float
    """Sample time of the records, s: every model steps at it and records it."""
    nlarx_scale: float = 1.0
    """Multiplies the NLARX training iterations."""
    units: tuple[str, str] = ("N", "m")
    """Input and output units as given (recorded in each model file)."""


@dataclass(frozen=True)
class Identified:
    """What :func:`identify_and_write` produced."""

    fits: dict[str, dict[str, Any]]
    """Per fitted kind, its validation fit report."""
    failed: dict[str, str]
    """Per kind that could not be fitted, the one-line reason."""
    paths: dict[str, Path]
    """Per fitted kind, its model file."""


def identify_and_write(records: Records, job: IdentifyJob, out: Path, prov: artifacts.Provenance,
                       on_saved: Callable[[str, Path], None] | None = None,
                       on_failed: Callable[[str, str], None] | None = None) -> Identified:
    """Fit every kind of ``job`` on ``records``, writing each model under ``out`` as it is fitted
    (``on_saved`` hears of it; ``on_failed`` of a kind that failed), then ``fits.json``."""
    rig = PlantParams(L=job.stroke, F=job.force, dt=job.dt)  # only these are known of the rig
    _refuse_existing(out, job.models)  # before any fit: a refused write is not a kind's failure
    paths: dict[str, Path] = {}
    fits: dict[str, FitReport] = {}
    failed: dict[str, str] = {}
    for name in job.models:  # one call per kind: each model is written, or its failure heard, at once
        model, fit, bad = identify_each(records, (name,), job.seed, rig, job.nlarx_scale, units=job.units)
        if name in model:  # the write is outside the fit's failures: a failing disk stops the run
            paths[name] = written(partial(write_models, out, model, fit, prov), out)[name]
            if on_saved is not None:
                on_saved(name, paths[name])
        fits.update(fit)
        failed.update(bad)
        if bad and on_failed is not None:
            on_failed(name, bad[name])
    report = {name: asdict(f) for name, f in fits.items()}
    written(lambda: write_fits(out, report, failed), out)
    return Identified(report, failed, paths)


def _refuse_existing(out: Path, models: Sequence[str]) -> None:
    """One-line OutputError if a file this run would write is already under ``out`` (never overwritten)."""
    for name in [*(f"{m}.json" for m in models), "fits.json"]:
        if (out / name).exists():
            raise OutputError(f"{out / name}: already exists; refusing to overwrite (choose another output "
                              "directory)")


def write_fits(out: Path, report: dict[str, Any], failed: dict[str, str]) -> Path:
    """``fits.json``: a fit report per fitted kind, and the failed kinds under :data:`FAILED_KEY`."""
    doc = {**report, FAILED_KEY: dict(failed)} if failed else report
    text = json.dumps(artifacts.jsonable(doc), indent=1) + "\n"
    return write_text_atomic(out / "fits.json", text, root=out)


def written(write: Callable[[], _T], out: Path) -> _T:
    """Run a write; a failing disk is the one-line OutputError naming ``out``."""
    try:
        return write()
    except OSError as exc:
        raise OutputError(f"out_dir {out}: writing the models failed ({exc.strerror or exc})") from None


def failure_lines(failed: dict[str, str], where: Callable[[str], str] | None = None) -> Sequence[str]:
    """One line per failed kind (``where`` adds which records it was fitted on)."""
    return [f"fitting {name} on {where(name)}: {why}" if where else f"fitting {name}: {why}"
            for name, why in failed.items()]
