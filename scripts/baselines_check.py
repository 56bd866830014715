"""Classical baselines on the design identification seeds: nominal successes and scenario cells.

For each identification seed (default 90, 91, 92: design seeds, never the
reported ones) the paper's records are made and the surrogates identified
exactly as ``msd-bench paper`` does (app.pipeline), or the pinned models are
used (``--pinned``). Each baseline kind (``glm+pid``, ``glm+pid-continuous``,
``greybox+lqr``, ``plm+mpc`` by default) is designed per set-point and
validated on the true plant under the scenario suite; a deterministic design
has one run per identification seed and condition, and one per noise draw
under sensor noise (``--draws`` draws per id seed). Prints per kind the
nominal successes at ±0.5, ±1, ±1.5 m and every scenario cell; ``--json`` writes
the cells, ``--out`` one provenance-stamped document (command, commit, machine,
seconds, kinds, id seeds, per scenario per kind n, successes, median MAE and
SSE, and each kind's design facts at 1 m per id seed) that
``scripts/readme_results.py`` renders into docs/baselines.md. Design options
are passed as ``--opt kind key=value`` (e.g. ``--opt glm+pid crossover=3``).

    .venv/bin/python scripts/baselines_check.py [--id-seeds 90 91 92] [--pinned] [--json out.json]
        [--out docs/results/baselines_design.json]
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, make_records
from msd_bench.app.scoring import Validation, record_cells
from msd_bench.core.baselines import designs
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.evaluation.robustness import merge
from msd_bench.core.evaluation.scenarios import parse, suite
from msd_bench.core.physics.model import StepModel
from msd_bench.designs.baselines import baseline_policy
from msd_bench.io.storage.artifacts import load_model

KINDS = ("glm+pid", "glm+pid-continuous", "greybox+lqr", "plm+mpc")
SETPOINTS = (-1.5, -1.0, -0.5, 0.5, 1.0, 1.5)
REPO = Path(__file__).resolve().parents[1]
PINNED = REPO / "tests" / "data" / "pinned"
ARRAYS = ("forces", "observer_gain", "k", "s_eq")
"""Design-artifact arrays left out of ``--out``: the document records tuning facts, not gains to reuse."""


def models_for(id_seed: int, surrogates: Sequence[str], pinned: bool) -> dict[str, StepModel]:
    """The surrogates of one identification seed (or the pinned ones)."""
    if pinned:
        return {s: load_model(PINNED / f"{s}.json") for s in surrogates}
    cfg = RunConfig()
    models, _ = identify_surrogates(make_records(cfg, id_seed), list(surrogates), id_seed, cfg.plant)
    return models


def options(pairs: Sequence[Sequence[str]]) -> dict[str, dict[str, Any]]:
    """``--opt kind key=value`` items as per-kind keyword options (numbers, or tuples of ints for blocks)."""
    out: dict[str, dict[str, Any]] = {}
    for kind, item in pairs:
        key, _, raw = item.partition("=")
        try:
            value: Any = tuple(int(v) for v in raw.split("/")) if "/" in raw else float(raw)
        except ValueError:
            raise ConfigError(f"--opt {kind} {item!r}: need key=number or key=n1/n2/... (blocks)") from None
        out.setdefault(kind, {})[key] = value
    return out


def run(kinds: Sequence[str], id_seeds: Sequence[int], pinned: bool, draws: int,
        opts: dict[str, dict[str, Any]]) -> tuple[dict[str, dict[str, Any]], dict[str, list[dict[str, Any]]]]:
    """Per kind: nominal set-point cells and scenario cells pooled over identification seeds, and the
    design facts at 1 m per identification seed."""
    cfg = RunConfig()
    scenarios = suite(tuple(f"setpoint={s:g}" for s in SETPOINTS if s != 1.0))
    parsed = [designs.parse_kind(k) for k in kinds]
    parts: dict[str, list[dict[str, dict[str, Any]]]] = {k: [] for k in kinds}
    facts: dict[str, list[dict[str, Any]]] = {k: [] for k in kinds}
    for id_seed in id_seeds:
        models = models_for(id_seed, sorted({s for s, _ in parsed}), pinned)
        noise_seeds = [id_seed * 1000 + i for i in range(draws)]
        for kind, (surrogate, name) in zip(kinds, parsed, strict=True):
            policy = baseline_policy(name, models[surrogate], cfg.plant, **opts.get(kind, {}))
            cells = record_cells(policy, noise_seeds,
                                 Validation(cfg.plant, scenarios, cfg.validation_steps, cfg.window))
            parts[kind].append(cells)
            at_1m = facts_at_1m(name, models[surrogate], opts.get(kind, {}))
            facts[kind].append({"id_seed": id_seed, **at_1m})
            print(f"id seed {id_seed} {kind}: nominal set-points "
                  + " ".join(f"{s:+g}:{_sid(s)}={cells[_sid(s)]['median_sse']:.2f}%" for s in SETPOINTS),
                  file=sys.stderr, flush=True)
    return {k: merge(p) for k, p in parts.items()}, facts


def facts_at_1m(name: str, model: StepModel, opts: dict[str, Any]) -> dict[str, Any]:
    """One kind's design at 1 m (``as_dict`` without its arrays), e.g. the PID's achieved phase margin
    and crossover, so the document shows what the constants gave."""
    cfg = RunConfig()
    d = designs.make(name, model, 1.0, cfg.plant.F, cfg.plant.dt, **opts)
    return {k: v for k, v in d.as_dict().items() if k not in ARRAYS}


def provenance() -> dict[str, Any]:
    """Command, commit and machine, taken before the run: the commit is the code that ran, even if
    the tree moves while it runs."""
    sys.path.insert(0, str(REPO / "scripts"))
    from make_results import commit, machine

    return {"command": "scripts/baselines_check.py " + shlex.join(sys.argv[1:]), "commit": commit(),
            "machine": machine()}


def document(result: dict[str, dict[str, Any]], facts: dict[str, list[dict[str, Any]]],
             args: argparse.Namespace, prov: dict[str, Any], seconds: float) -> dict[str, Any]:
    """The ``--out`` document: provenance, then per scenario per kind the cell without its run lists."""
    kinds = list(result)
    scenarios = list(result[kinds[0]])
    keep = ("n", "n_success", "median_mae", "median_sse")
    return {**prov, "seconds": round(seconds, 1), "kinds": kinds,
            "id_seeds": list(args.id_seeds), "pinned": args.pinned, "draws": args.draws,
            "options": options(args.opt), "setpoints": list(SETPOINTS), "scenarios": scenarios,
            "cells": {sid: {k: {f: result[k][sid][f] for f in keep} for k in kinds} for sid in scenarios},
            "designs": facts}


def _sid(setpoint: float) -> str:
    return "nominal" if setpoint == 1.0 else parse(f"setpoint={setpoint:g}").id


def report(result: dict[str, dict[str, Any]]) -> None:
    """Per kind: nominal successes over the six set-points, then every scenario cell."""
    for kind, cells in result.items():
        nominal = [cells[_sid(s)] for s in SETPOINTS]
        wins, n = sum(c["n_success"] for c in nominal), sum(c["n"] for c in nominal)
        print(f"\n{kind}: nominal set-points ±0.5, ±1, ±1.5 m: {wins}/{n} successes")
        for sid, c in cells.items():
            print(f"  {sid:38s} {c['n_success']:3d}/{c['n']:<3d} median SSE {c['median_sse']:7.2f} %  "
                  f"median MAE {c['median_mae']:.3f} m")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", nargs="+", default=list(KINDS))
    ap.add_argument("--id-seeds", nargs="+", type=int, default=[90, 91, 92])
    ap.add_argument("--pinned", action="store_true", help="use tests/data/pinned instead of identifying")
    ap.add_argument("--draws", type=int, default=4, help="sensor-noise draws per id seed and noisy scenario")
    ap.add_argument("--opt", nargs=2, action="append", default=[], metavar=("KIND", "KEY=VALUE"))
    ap.add_argument("--json", type=Path, help="also write the cells here (must not exist)")
    ap.add_argument("--out", type=Path, help="write the provenance-stamped document here (must not exist)")
    args = ap.parse_args()
    start = time.monotonic()
    try:
        for path in (args.json, args.out):
            if path is not None and path.exists():
                raise MsdBenchError(f"{path} exists; not overwriting it")
            if path is not None and not path.parent.is_dir():
                raise MsdBenchError(f"{path}: directory {path.parent} does not exist")
        opts = options(args.opt)
        prov = provenance() if args.out is not None else {}
        result, facts = run(args.kinds, args.id_seeds, args.pinned, args.draws, opts)
    except MsdBenchError as e:
        print(f"baselines_check: {e}", file=sys.stderr)
        return 2
    report(result)
    try:
        if args.json is not None:
            with args.json.open("x") as f:
                json.dump(result, f, indent=1)
        if args.out is not None:
            with args.out.open("x") as f:
                json.dump(document(result, facts, args, prov, time.monotonic() - start), f, indent=1)
                f.write("\n")
    except OSError as e:
        print(f"baselines_check: cannot write {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
