"""``msd-bench paper`` as tasks an executor runs: one per identification seed, one per on-plant kind.

Why these tasks: an identification seed is the unit the method repeats —
records, every model kind fitted on them, every surrogate kind's policy made on
its model, validated nominally and under the scenario suite — and nothing in it
depends on another seed. An on-plant kind trains on the plant once per run.
Each task runs in a worker (:mod:`msd_bench.app.executor`) and returns a
:class:`Part`; the driver writes it at once as the task's files:

    models/id<s>/<model>.json          each surrogate, its validation fit in ``info``
    policies/<kind>/id<s>/             each kind's trained-policy artifact (as bench.py's agents write)
    parts/<task>.json                  per kind: seeds, per-seed rows, robustness cells
    parts/<task>.npz                   per kind: the nominal closed-loop positions (for the figures)

Table 1, robustness and the figures are then assembled from those files only
(:func:`load_run`), so a run resumed after a kill — whose finished tasks are
read back, not recomputed — writes what an uninterrupted run writes.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.executor import task_name
from msd_bench.app.pipeline import (
    PaperRun,
    Trained,
    identify_surrogates,
    make_records,
    settings,
    train_and_validate,
)
from msd_bench.app.scoring import PolicyRecord, Validation, assemble, record_cells
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.physics.model import StepModel, check_rate, plant_model
from msd_bench.designs.kinds import made_on_plant
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.atomic import savez_atomic, write_text_atomic
from msd_bench.io.storage.run_dir import RunDir, RunDirError
from msd_bench.io.storage.run_fields import is_int, seed_row
from msd_bench.io.storage.run_output import write_models
from msd_bench.io.storage.safe_npz import read_npz_bounded
from msd_bench.io.storage.safe_read import read_json_bounded

Found = tuple[PolicyRecord, dict[str, dict[str, Any]], np.ndarray]
"""A kind's record read back from a part: the policy and its rows, its robustness cells, its responses."""

PART_SCHEMA = "msd-bench/paper-part"
PART_VERSION = 1


@dataclass(frozen=True)
class Part:
    """What one task made: its models (an identification seed's) and each kind's validated policy."""

    task: str
    id_seed: int
    models: dict[str, StepModel]
    fits: dict[str, FitReport]
    trained: dict[str, Trained]
    cells: dict[str, dict[str, dict[str, Any]]]
    """Per kind: its robustness cells (empty when the run has no scenario suite)."""


def part_tasks(cfg: RunConfig) -> list[tuple[str, str, Any]]:
    """``(task id, what, argument)``: ``("id0", "identification", 0)`` per identification seed index,
    ``("plant-dyna-q", "plant", "dyna-q")`` per on-plant kind."""
    by_id = [(f"id{s}", "identification", i) for i, s in enumerate(cfg.id_seed_values())]
    on_plant = [(f"plant-{task_name(k)}", "plant", k) for k in cfg.plant_agents()]
    return by_id + on_plant



def _cells(trained: Trained, cfg: RunConfig, scenarios: bool) -> dict[str, dict[str, Any]]:
    return record_cells(trained.policy, trained.seeds, Validation.of(cfg, scenarios))


def identification_part(cfg: RunConfig, i: int, scenarios: bool = True) -> Part:
    """The ``i``-th identification seed: records, models, every surrogate kind made and validated."""
    id_seed = cfg.id_seed_values()[i]
    models, fits = identify_surrogates(make_records(cfg, id_seed), cfg.surrogates_needed(), id_seed,
                                       cfg.plant, cfg.nlarx_scale)
    trained = {a: train_and_validate(a, models[agent_kind(a).surrogate], cfg, cfg.learning_seeds(i), id_seed)
               for a in cfg.surrogate_agents()}
    return Part(f"id{id_seed}", id_seed, models, fits, trained,
                {a: _cells(t, cfg, scenarios) for a, t in trained.items()})


def plant_part(cfg: RunConfig, kind: str, scenarios: bool = True) -> Part:
    """An on-plant kind, trained on the plant once, with the first identification seed's learning seeds."""
    t = train_and_validate(kind, plant_model(cfg.plant), cfg, cfg.learning_seeds(0))
    return Part(f"plant-{task_name(kind)}", cfg.id_first_seed, {}, {}, {kind: t},
                {kind: _cells(t, cfg, scenarios)})


def save_part(rd: RunDir, part: Part, provenance: artifacts.Provenance) -> list[Path]:
    """The part's files under the run (its models, policies, rows, cells and responses)."""
    root = rd.root
    paths = list(write_models(root / "models" / f"id{part.id_seed}", part.models, part.fits, provenance,
                              root=root, overwrite=True).values())
    for kind, t in part.trained.items():
        prov = {**provenance.as_dict(), "id_seed": part.id_seed}
        paths += designs.save(t.policy, root / "policies" / kind / f"id{part.id_seed}", prov, root, True)
    doc = {"schema": PART_SCHEMA, "schema_version": PART_VERSION, "task": part.task, "id_seed": part.id_seed,
           "kinds": {k: {"seeds": list(t.seeds), "per_seed": list(t.record(None).per_seed),
                         "cells": part.cells[k]} for k, t in part.trained.items()}}
    paths.append(write_text_atomic(root / "parts" / f"{part.task}.json",
                                   json.dumps(artifacts.jsonable(doc), indent=1) + "\n", root=root))
    paths.append(savez_atomic(root / "parts" / f"{part.task}.npz",
                              {k: t.x for k, t in part.trained.items()}, root=root))
    return paths


def load_run(rd: RunDir, cfg: RunConfig, scenarios: bool = True) -> PaperRun:
    """The run's Table 1, robustness, models, policies and responses, read back from its part files."""
    run = PaperRun(cfg)
    found: dict[str, list[Found]] = {a: [] for a in cfg.agents}
    for task, what, _ in part_tasks(cfg):
        id_seed = int(task[2:]) if what == "identification" else cfg.id_first_seed
        if what == "identification":
            run.models[id_seed], run.fits[id_seed] = _models(rd.root / "models" / f"id{id_seed}", cfg)
        doc = read_json_bounded(rd.root / "parts" / f"{task}.json", RunDirError)
        xs = read_npz_bounded(rd.root / "parts" / f"{task}.npz", RunDirError)
        if doc.get("schema") != PART_SCHEMA or doc.get("schema_version") != PART_VERSION:
            raise RunDirError(f"{rd.root / 'parts' / task}.json is not a paper part of this msd-bench")
        for kind, entry in _part_kinds(doc, rd.root / "parts" / f"{task}.json").items():
            if kind not in xs:
                raise RunDirError(f"{rd.root / 'parts' / task}.npz: no responses of kind {kind}")
            surrogate = agent_kind(kind).surrogate
            model = plant_model(cfg.plant) if made_on_plant(kind) else run.models[id_seed][surrogate]
            policy = designs.load(rd.root / "policies" / kind / f"id{id_seed}", model)
            fit = run.fits.get(id_seed, {}).get(surrogate)
            record = PolicyRecord(policy, id_seed, entry["seeds"], entry["per_seed"], fit)
            found[kind].append((record, entry["cells"], xs[kind]))
            run.policies.setdefault(kind, {})[id_seed] = policy
    for kind in cfg.agents:
        _collect(run, kind, found[kind], scenarios)
    first = cfg.id_first_seed
    run.records[first] = make_records(cfg, first)  # the figures' records: cheap to make again, seeded
    return run


def _part_kinds(doc: dict[str, Any], path: Path) -> dict[str, dict[str, Any]]:
    """A part's ``kinds``, every field the report stage reads type-checked (one line naming it)."""
    kinds = doc.get("kinds")
    if not isinstance(kinds, dict):
        raise RunDirError(f"{path}: kinds must be an object")
    for kind, entry in kinds.items():
        where = f"kinds[{kind!r}]"
        if not isinstance(entry, dict):
            raise RunDirError(f"{path}: {where} must be an object")
        seeds, rows = entry.get("seeds"), entry.get("per_seed")
        if not isinstance(seeds, list) or not all(is_int(x) for x in seeds):
            raise RunDirError(f"{path}: {where}.seeds must be a list of integers")
        if not isinstance(rows, list) or not 1 <= len(rows) <= len(seeds):
            # one row per member: a learned kind's per seed, a deterministic design's one nominal run
            raise RunDirError(f"{path}: {where}.per_seed must be a list of one row per member "
                              f"(1..{len(seeds)} for {len(seeds)} seed(s))")
        for i, row in enumerate(rows):
            seed_row(row, f"{where}.per_seed[{i}]", path, RunDirError)
        if not isinstance(entry.get("cells"), dict):
            raise RunDirError(f"{path}: {where}.cells must be an object")
    return kinds


def _collect(run: PaperRun, kind: str, parts: Sequence[Found], scenarios: bool) -> None:
    """Table-1 row and robustness of one kind from its parts (:func:`msd_bench.app.scoring.assemble`)."""
    cfg = run.config
    val = Validation.of(cfg, scenarios)
    result, rob = assemble(kind, [r for r, _, _ in parts], settings(cfg), val,
                           cells=[cells for _, cells, _ in parts])
    run.results.append(result)
    if scenarios:
        run.robustness[kind] = rob
    run.responses[kind] = np.concatenate([x for _, _, x in parts])


def _models(directory: Path, cfg: RunConfig) -> tuple[dict[str, StepModel], dict[str, FitReport]]:
    """An identification seed's surrogates and their validation fits, read back from their artifacts."""
    models: dict[str, StepModel] = {}
    fits: dict[str, FitReport] = {}
    for name in cfg.surrogates_needed():
        models[name] = artifacts.load_model(directory / f"{name}.json")
        check_rate(models[name], cfg.plant.dt, "the run's plant")
        doc = models[name].info.get("validation_fit")
        if isinstance(doc, dict):
            try:
                fits[name] = FitReport(**doc)
            except TypeError:
                raise RunDirError(f"{directory / name}.json: its validation fit does not fit this "
                                  "msd-bench") from None
    return models, fits
